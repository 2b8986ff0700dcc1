# Reference values for analysis/stats.py, computed in R. The tests compare against the CSV files
# this script writes next to itself; they do not need R.
#
#   cd tests/analysis/R && Rscript reference.R
#
# Every file starts with comment lines naming the R version and the packages that made it.
# Numbers are written with 17 significant digits, so they read back as the same doubles.

suppressPackageStartupMessages({
  library(car)
  library(afex)
  library(multcompView)
})

HEADER <- c(
  sprintf("# made by tests/analysis/R/reference.R with %s", R.version.string),
  sprintf(
    "# packages: car %s, afex %s, multcompView %s, stats %s",
    packageVersion("car"), packageVersion("afex"), packageVersion("multcompView"),
    packageVersion("stats")
  )
)

number <- function(x) ifelse(is.na(x), "NA", sprintf("%.17g", x))

write_reference <- function(table, file, note) {
  con <- file(file, "w")
  writeLines(c(HEADER, paste("#", note)), con)
  write.csv(table, con, row.names = FALSE, quote = TRUE, na = "NA")
  close(con)
}

# ---------------------------------------------------------------- repeated-measures ANOVA
# Data: a subject intercept, per-subject slopes over each factor's level index, and noise whose
# SD grows with the first factor's level by `spread` (spread > 0 violates sphericity).
make_design <- function(factors, n, seed, subject = "subject", spread = 0.6, slope = 0.3) {
  set.seed(seed)
  levels <- lapply(factors, function(k) sprintf("L%d", seq_len(k)))
  grid <- expand.grid(c(list(.s = seq_len(n)), levels), stringsAsFactors = FALSE)
  intercept <- rnorm(n)
  slopes <- matrix(rnorm(n * length(factors), slope, abs(slope)), n)
  index <- sapply(names(factors), function(f) match(grid[[f]], levels[[f]]))
  index <- matrix(index, nrow(grid))
  mean <- intercept[grid$.s] + rowSums(slopes[grid$.s, , drop = FALSE] * index)
  y <- mean + rnorm(nrow(grid), 0, 1 + spread * (index[, 1] - 1))
  data <- data.frame(sprintf("S%02d", grid$.s), grid[names(factors)], round(y, 4))
  names(data) <- c(subject, names(factors), "y")
  data[order(data[[subject]]), ]
}

DESIGNS <- list(
  one_way_3 = list(factors = c(cue = 3), n = 10, seed = 1),
  one_way_6 = list(factors = c(level = 6), n = 10, seed = 2),
  # no sphericity violation in the population
  spherical_4 = list(factors = c(cue = 4), n = 12, seed = 3, spread = 0, slope = 0),
  # n - 1 equals the effect's df: the smallest estimable case
  boundary_5_by_5 = list(factors = c(step = 5), n = 5, seed = 4),
  yoshida_6x2 = list(factors = c(L_disk = 6, method = 2), n = 10, seed = 5),
  two_way_3x4 = list(factors = c(a = 3, b = 4), n = 12, seed = 6),
  three_way_3x4x2 = list(factors = c(a = 3, b = 4, d = 2), n = 9, seed = 7),
  three_way_2x3x3 = list(factors = c(x = 2, y3 = 3, z = 3), n = 7, seed = 8),
  # Spencer's shape: 8 subjects, 11 df for the level and the interaction: not estimable
  spencer_12x2 = list(factors = c(glare_level = 12, context = 2), n = 8, seed = 9),
  # names that are functions in R's and patsy's formulas
  formula_names = list(factors = c(C = 3, Q = 2), n = 8, seed = 10, subject = "I")
)

rows <- list()
for (name in names(DESIGNS)) {
  spec <- DESIGNS[[name]]
  subject <- if (is.null(spec$subject)) "subject" else spec$subject
  data <- make_design(
    spec$factors, spec$n, spec$seed, subject,
    spread = if (is.null(spec$spread)) 0.6 else spec$spread,
    slope = if (is.null(spec$slope)) 0.3 else spec$slope
  )
  file <- sprintf("anova_%s.csv", name)
  write_reference(data, file, sprintf("design %s: long format, one row per subject and cell", name))
  data <- read.csv(file, comment.char = "#", stringsAsFactors = FALSE)  # the stored numbers
  within <- names(spec$factors)
  formula <- as.formula(sprintf(
    "y ~ %s + Error(%s / (%s))", paste(within, collapse = " * "), subject,
    paste(within, collapse = " * ")
  ))
  fit <- suppressWarnings(suppressMessages(aov_car(formula, data = data)))
  tests <- suppressWarnings(summary(fit$Anova, multivariate = FALSE))
  univariate <- tests$univariate.tests
  effects <- setdiff(rownames(univariate), "(Intercept)")
  pes <- anova(fit, es = "pes", correction = "none")
  for (effect in effects) {
    singular <- fit$Anova$singular[[effect]]
    df1 <- univariate[effect, "num Df"]
    corrections <- tests$pval.adjustments
    has <- !singular && df1 > 1 && effect %in% rownames(corrections)
    mauchly <- tests$sphericity.tests
    rows[[length(rows) + 1]] <- data.frame(
      design = name,
      subject = subject,
      within = paste(within, collapse = ";"),
      n = spec$n,
      source = effect,
      df1 = number(df1),
      df2 = number(univariate[effect, "den Df"]),
      F = number(univariate[effect, "F value"]),
      p = number(univariate[effect, "Pr(>F)"]),
      singular = singular,
      eps_gg = number(if (has) corrections[effect, "GG eps"] else NA),
      p_gg = number(if (has) corrections[effect, "Pr(>F[GG])"] else NA),
      eps_hf_uncapped = number(if (has) corrections[effect, "HF eps"] else NA),
      p_hf = number(if (has) corrections[effect, "Pr(>F[HF])"] else NA),
      mauchly_W = number(if (has) mauchly[effect, "Test statistic"] else NA),
      mauchly_p = number(if (has) mauchly[effect, "p-value"] else NA),
      eta2_partial = number(pes[effect, "pes"])
    )
  }
}
write_reference(
  do.call(rbind, rows), "anova_results.csv",
  paste(
    "afex::aov_car and summary(car::Anova, multivariate = FALSE); eps_hf_uncapped is car's",
    "'HF eps' (Lecoutre's correction, printed uncapped), p_hf uses min(1, eps_hf) as car does;",
    "NA where R computes no correction: one df, or a singular error SSP matrix (singular)"
  )
)

# ---------------------------------------------------------------- Wilcoxon signed-rank test
set.seed(20)
WILCOXON <- list(
  exact_n7 = list(x = c(4.8, 5.6, 3.1, 6.2, 4.45, 5.9, 7.3), mu = 4),
  exact_n13 = list(x = round(rnorm(13, 4.6, 1.2), 3), mu = 4),
  exact_n20 = list(x = round(rnorm(20, 4.3, 1), 4), mu = 4),
  exact_n49 = list(x = round(rnorm(49, 4.3, 1), 5), mu = 4),
  normal_n50 = list(x = round(rnorm(50, 4.3, 1), 5), mu = 4),
  normal_n80 = list(x = round(rnorm(80, 3.8, 1), 5), mu = 4),
  all_above_n6 = list(x = c(4.5, 5, 6, 7, 8, 9.5), mu = 4),
  all_below_n10 = list(x = 4 - (1:10) / 7, mu = 4),
  single = list(x = 5.5, mu = 4),
  symmetric_p1 = list(x = 4 + c(-1, 2, -3, 4, -5, 6, 7, -8, 9, -10, 11, -12), mu = 4),
  # 4.1 - 4 and 3.9 - 4 differ in floating point: no tie, so the exact test
  decimal_not_tied = list(x = c(4.1, 3.9, 4.7, 5.3, 4.25, 6.0), mu = 4),
  ties = list(x = c(5, 6, 6, 3, 7, 5, 6, 2, 7, 6, 5), mu = 4),
  zeros = list(x = c(4, 5, 6, 4, 3, 7, 5, 4, 6, 2), mu = 4),
  likert_n10 = list(x = c(5, 5, 4, 6, 3, 5, 6, 4, 5, 7), mu = 4),
  likert_n40 = list(x = sample(1:7, 40, replace = TRUE, prob = c(1, 1, 2, 3, 4, 3, 2)), mu = 4),
  other_mu = list(x = round(rnorm(15, 0.4, 1), 3), mu = 0)
)
rows <- list()
for (name in names(WILCOXON)) {
  case <- WILCOXON[[name]]
  test <- suppressWarnings(wilcox.test(case$x, mu = case$mu))
  rows[[length(rows) + 1]] <- data.frame(
    case = name,
    mu = number(case$mu),
    x = paste(number(case$x), collapse = ";"),
    V = number(unname(test$statistic)),
    p = number(test$p.value),
    method = test$method
  )
}
write_reference(
  do.call(rbind, rows), "wilcoxon.csv",
  "wilcox.test(x, mu = mu) with R's defaults (exact = NULL, correct = TRUE); V as R reports it"
)

# ---------------------------------------------------------------- t-tests
set.seed(30)
TTESTS <- list(
  differing = list(a = round(rnorm(10, 0, 1), 4), b = round(rnorm(10, 0.8, 2.5), 4)),
  unequal_sd = list(a = round(rnorm(12, 5, 0.5), 4), b = round(rnorm(12, 4.6, 2), 4)),
  # the means agree to four decimals: p above .9995
  no_difference = list(
    a = c(1.2, 3.4, 2.2, 5.1, 4.4, 3.3, 2.9, 4.0),
    b = c(1.9, 2.6, 3.0, 4.7, 4.8, 3.1, 2.1, 4.3) + c(rep(0, 7), 0.0004)
  )
)
rows <- list()
for (name in names(TTESTS)) {
  case <- TTESTS[[name]]
  paired <- t.test(case$a, case$b, paired = TRUE)
  welch <- t.test(case$a, case$b)
  welch_greater <- t.test(case$a, case$b, alternative = "greater")
  rows[[length(rows) + 1]] <- data.frame(
    case = name,
    a = paste(number(case$a), collapse = ";"),
    b = paste(number(case$b), collapse = ";"),
    paired_t = number(unname(paired$statistic)),
    paired_df = number(unname(paired$parameter)),
    paired_p = number(paired$p.value),
    welch_t = number(unname(welch$statistic)),
    welch_df = number(unname(welch$parameter)),
    welch_p = number(welch$p.value),
    welch_p_greater = number(welch_greater$p.value)
  )
}
write_reference(
  do.call(rbind, rows), "ttests.csv",
  "t.test(a, b, paired = TRUE) and t.test(a, b) (Welch), two-sided; Welch one-sided 'greater'"
)

# ---------------------------------------------------------------- pairwise tests, Holm, letters
set.seed(40)
shift <- c(L1 = 0, L2 = 0.1, L3 = 1.2, L4 = 1.3, L5 = 2.8)
grid <- expand.grid(subject = sprintf("S%02d", 1:10), level = names(shift),
                    stringsAsFactors = FALSE)
grid$y <- round(rnorm(10)[match(grid$subject, sprintf("S%02d", 1:10))] + shift[grid$level] +
                  rnorm(nrow(grid), 0, 0.6), 4)
write_reference(grid, "pairwise_data.csv", "long format: 10 subjects × 5 levels")
grid <- read.csv("pairwise_data.csv", comment.char = "#", stringsAsFactors = FALSE)
wide <- reshape(grid, idvar = "subject", timevar = "level", direction = "wide")
pairs <- combn(names(shift), 2)
rows <- list()
for (j in seq_len(ncol(pairs))) {
  test <- t.test(wide[[paste0("y.", pairs[1, j])]], wide[[paste0("y.", pairs[2, j])]],
                 paired = TRUE)
  rows[[j]] <- data.frame(a = pairs[1, j], b = pairs[2, j], t = unname(test$statistic),
                          df = unname(test$parameter), p = test$p.value)
}
pairwise <- do.call(rbind, rows)
pairwise$p_holm <- p.adjust(pairwise$p, method = "holm")
letters <- multcompLetters(setNames(pairwise$p_holm, paste(pairwise$a, pairwise$b, sep = "-")),
                           threshold = 0.05)$Letters
pairwise$letters_a <- unname(letters[pairwise$a])
pairwise$letters_b <- unname(letters[pairwise$b])
for (column in c("t", "df", "p", "p_holm")) pairwise[[column]] <- number(pairwise[[column]])
write_reference(
  pairwise, "pairwise_results.csv",
  paste("paired t.test per pair, p.adjust(method = 'holm'),",
        "multcompView::multcompLetters(p_holm, threshold = 0.05)")
)

# ================================================================ issue: effect sizes and edges
# Designs other than the ones above: generalized eta squared (afex), the CI of partial eta
# squared (noncentral F, solved with uniroot; effectsize's optim-based limits alongside),
# marginal means (emmeans on the afex fit), Cousineau-Morey within-subject intervals and
# Shapiro-Wilk of the residuals.
suppressPackageStartupMessages({
  library(emmeans)
  library(effectsize)
})
HEADER <- c(HEADER, sprintf(
  "# and: emmeans %s, effectsize %s", packageVersion("emmeans"), packageVersion("effectsize")
))

ncp_root <- function(cdf, probability, start) {
  if (cdf(0) < probability) return(0)
  high <- max(10, start)
  while (cdf(high) > probability) high <- 2 * high + 1
  uniroot(function(x) cdf(x) - probability, c(0, high), tol = 1e-15)$root
}
eta2_ci <- function(f, df1, df2, level = 0.90) {
  alpha <- 1 - level
  lambda <- sapply(c(1 - alpha / 2, alpha / 2), function(prob)
    ncp_root(function(x) pf(f, df1, df2, ncp = x), prob, 2 * f * df1))
  lambda / (lambda + df2)
}

EFFECT_DESIGNS <- list(
  es_3x5 = list(factors = c(a = 3, b = 5), n = 12, seed = 51),
  es_one_way_4 = list(factors = c(cue = 4), n = 20, seed = 52),
  es_2x2x3 = list(factors = c(p = 2, q = 2, r = 3), n = 6, seed = 53),
  es_2x6_n3 = list(factors = c(level = 6, method = 2), n = 3, seed = 54, spread = 0.1)
)
rows <- list()
means <- list()
cells <- list()
for (name in names(EFFECT_DESIGNS)) {
  spec <- EFFECT_DESIGNS[[name]]
  data <- make_design(spec$factors, spec$n, spec$seed,
                      spread = if (is.null(spec$spread)) 0.6 else spec$spread)
  file <- sprintf("effects_%s.csv", name)
  write_reference(data, file, sprintf("design %s: long format, one row per subject and cell", name))
  data <- read.csv(file, comment.char = "#", stringsAsFactors = FALSE)
  within <- names(spec$factors)
  formula <- as.formula(sprintf(
    "y ~ %s + Error(subject / (%s))", paste(within, collapse = " * "),
    paste(within, collapse = " * ")
  ))
  fit <- suppressWarnings(suppressMessages(aov_car(formula, data = data)))
  table <- anova(fit, es = c("ges", "pes"), correction = "none")
  for (effect in rownames(table)) {
    f <- table[effect, "F"]
    df1 <- table[effect, "num Df"]
    df2 <- table[effect, "den Df"]
    ci <- eta2_ci(f, df1, df2)
    es <- F_to_eta2(f, df1, df2, ci = 0.90, alternative = "two.sided")
    rows[[length(rows) + 1]] <- data.frame(
      design = name, source = effect, F = number(f), df1 = number(df1), df2 = number(df2),
      eta2_partial = number(table[effect, "pes"]),
      eta2_generalized = number(table[effect, "ges"]),
      eta2p_ci_low = number(ci[1]), eta2p_ci_high = number(ci[2]),
      effectsize_ci_low = number(es$CI_low), effectsize_ci_high = number(es$CI_high)
    )
  }
  for (factor in within) {
    em <- suppressMessages(summary(emmeans(fit, as.formula(paste("~", factor)))))
    means[[length(means) + 1]] <- data.frame(
      design = name, factor = factor, level = as.character(em[[factor]]),
      emmean = number(em$emmean), se = number(em$SE), df = number(em$df),
      ci_low = number(em$lower.CL), ci_high = number(em$upper.CL)
    )
  }
  # Cousineau (2005) normalisation with Morey's (2008) correction, written out
  data$cell <- interaction(data[within], sep = ":", lex.order = TRUE)
  wide <- tapply(data$y, list(data$subject, data$cell), identity)
  k <- ncol(wide)
  normalised <- wide - rowMeans(wide) + mean(wide)
  sem <- apply(normalised, 2, sd) * sqrt(k / (k - 1)) / sqrt(nrow(wide))
  residuals <- sweep(sweep(wide, 1, rowMeans(wide)), 2, colMeans(wide)) + mean(wide)
  shapiro <- shapiro.test(as.vector(t(residuals)))
  cells[[length(cells) + 1]] <- data.frame(
    design = name, cell = colnames(wide), mean = number(colMeans(wide)),
    sem_within = number(sem), ci_half = number(qt(0.975, nrow(wide) - 1) * sem),
    residuals_shapiro_W = number(unname(shapiro$statistic)),
    residuals_shapiro_p = number(shapiro$p.value)
  )
}
write_reference(
  do.call(rbind, rows), "effects_anova.csv",
  paste(
    "anova(aov_car fit, es = c('ges', 'pes'), correction = 'none'); eta2p_ci: two-sided 90 %,",
    "the noncentral F inverted with uniroot (tol 1e-15), lambda / (lambda + df2);",
    "effectsize_ci: effectsize::F_to_eta2(ci = 0.90, alternative = 'two.sided') (optim)"
  )
)
write_reference(do.call(rbind, means), "effects_emmeans.csv",
                "summary(emmeans(aov_car fit, ~ factor)) (afex's default multivariate model)")
write_reference(
  do.call(rbind, cells), "effects_within_ci.csv",
  paste("Cousineau-Morey: y - subject mean + grand mean, SD * sqrt(k / (k - 1)) / sqrt(n),",
        "half-width qt(.975, n - 1) * SEM; shapiro.test of y - subject - cell + grand means")
)

# ---------------------------------------------------------------- paired effects
nct_root <- function(t, df, probability) {
  uniroot(function(x) pt(t, df, ncp = x) - probability, t + c(-1, 1) * (abs(t) + 50),
          tol = 1e-15)$root
}
set.seed(60)
PAIRS <- list(
  n5 = list(a = c(5.1, 6.0, 5.8, 6.4, 5.5), b = c(4.2, 5.1, 5.9, 5.0, 4.8)),
  n12 = list(a = round(rnorm(12, 10, 2), 3), b = round(rnorm(12, 9, 2), 3)),
  n40_small = list(a = round(rnorm(40, 0, 1), 4), b = round(rnorm(40, 0.1, 1), 4)),
  offset_1e6 = list(a = 1e6 + round(rnorm(9, 0, 1), 4), b = 1e6 + round(rnorm(9, 1.5, 1), 4)),
  negative = list(a = round(rnorm(15, 0, 1), 4), b = round(rnorm(15, 2, 1), 4))
)
rows <- list()
for (name in names(PAIRS)) {
  case <- PAIRS[[name]]
  d <- case$a - case$b
  n <- length(d)
  test <- t.test(case$a, case$b, paired = TRUE)
  t <- unname(test$statistic)
  dz <- cohens_d(case$a, case$b, paired = TRUE, ci = 0.95)
  rows[[length(rows) + 1]] <- data.frame(
    case = name,
    a = paste(number(case$a), collapse = ";"), b = paste(number(case$b), collapse = ";"),
    mean_difference = number(mean(d)),
    md_ci_low = number(test$conf.int[1]), md_ci_high = number(test$conf.int[2]),
    d_z = number(mean(d) / sd(d)),
    dz_ci_low = number(nct_root(t, n - 1, 0.975) / sqrt(n)),
    dz_ci_high = number(nct_root(t, n - 1, 0.025) / sqrt(n)),
    effectsize_d = number(dz$Cohens_d),
    effectsize_ci_low = number(dz$CI_low), effectsize_ci_high = number(dz$CI_high)
  )
}
write_reference(
  do.call(rbind, rows), "effects_paired.csv",
  paste("t.test(a, b, paired = TRUE)$conf.int; d_z = mean(d) / sd(d) with the noncentral t",
        "inverted by uniroot (tol 1e-15), ncp / sqrt(n); effectsize::cohens_d(paired = TRUE)")
)

# ---------------------------------------------------------------- Wilcoxon effect sizes
set.seed(70)
RANKS <- list(
  exact_n9 = list(x = c(4.3, 5.1, 3.2, 6.6, 4.9, 5.7, 2.8, 6.1, 5.3), mu = 4),
  exact_n25 = list(x = round(rnorm(25, 0.3, 1), 4), mu = 0),
  likert_ties_zeros = list(x = c(7, 5, 3, 6, 6, 6, 6, 4), mu = 4),
  likert_n30 = list(x = sample(1:7, 30, replace = TRUE), mu = 4),
  all_above = list(x = c(5, 6, 7, 5, 6), mu = 4),
  differences = list(x = c(-1, -2, 0, -1, -3, 1, -2, 0, -1, -2), mu = 0)
)
rows <- list()
for (name in names(RANKS)) {
  case <- RANKS[[name]]
  d <- case$x - case$mu
  test <- suppressWarnings(wilcox.test(case$x, mu = case$mu, conf.int = TRUE))
  rb <- rank_biserial(case$x, mu = case$mu, ci = 0.95)
  walsh <- outer(d, d, "+") / 2
  exact <- test$method == "Wilcoxon signed rank exact test"
  rows[[length(rows) + 1]] <- data.frame(
    case = name, mu = number(case$mu), x = paste(number(case$x), collapse = ";"),
    r_rb = number(rb$r_rank_biserial), rb_ci_low = number(rb$CI_low),
    rb_ci_high = number(rb$CI_high),
    walsh_median = number(median(walsh[upper.tri(walsh, diag = TRUE)])),
    wilcox_estimate = number(unname(test$estimate)),
    exact = exact
  )
}
write_reference(
  do.call(rbind, rows), "effects_wilcoxon.csv",
  paste("effectsize::rank_biserial(x, mu = mu, ci = 0.95); walsh_median: the median of the",
        "Walsh averages of x - mu; wilcox_estimate: wilcox.test(conf.int = TRUE)$estimate",
        "(the Walsh median where exact is TRUE, a uniroot solution with tol 1e-4 otherwise)")
)

# ---------------------------------------------------------------- a Holm family without NA
# The issue's questionnaire: one category every participant rated at the midpoint; R's
# wilcox.test gives NaN for it and p.adjust leaves it out of the family.
QUESTIONNAIRE <- list(
  "Glare Appearance" = rep(4, 8),
  "Overall" = c(7, 5, 3, 6, 6, 6, 6, 4),
  "Brightness" = c(5, 6, 4, 5, 7, 3, 5, 6),
  "Realism" = c(3, 4, 2, 5, 4, 3, 2, 4)
)
tests <- lapply(QUESTIONNAIRE, function(x) suppressWarnings(wilcox.test(x, mu = 4)))
p <- sapply(tests, function(t) t$p.value)
write_reference(
  data.frame(
    category = names(QUESTIONNAIRE),
    ratings = sapply(QUESTIONNAIRE, function(x) paste(x, collapse = ";")),
    V = number(sapply(tests, function(t) unname(t$statistic))),
    p = number(p), p_holm = number(p.adjust(p, method = "holm"))
  ),
  "holm_family.csv",
  "wilcox.test(x, mu = 4) per category, p.adjust(p, 'holm'): NaN (NA) is left out of the family"
)

# ---------------------------------------------------------------- letters beyond the alphabet
# Nine levels in three triples: every pair inside a triple differs, no pair across: the
# 27 maximal groups (one level of each triple) need more than 26 letters.
LEVELS <- sprintf("T%d%d", rep(1:3, each = 3), rep(1:3, 3))
pairs <- combn(LEVELS, 2)
p <- ifelse(substr(pairs[1, ], 2, 2) == substr(pairs[2, ], 2, 2), 0.001, 0.5)
letters <- multcompLetters(setNames(p, paste(pairs[1, ], pairs[2, ], sep = "-")))$Letters
write_reference(
  data.frame(a = pairs[1, ], b = pairs[2, ], p_adjusted = number(p)),
  "letters_27_pairs.csv", "nine levels, 36 pairs: the adjusted p-values given to multcompLetters"
)
write_reference(
  data.frame(level = names(letters), letters = unname(letters)),
  "letters_27.csv", "multcompView::multcompLetters(p, threshold = 0.05)$Letters"
)

# ---------------------------------------------------------------- psychometric fits
# glm(y ~ disc_fraction, binomial) per staircase of psychometric_staircases.csv (written by a
# simulated study, see its header); "neither" is y = 0.5, which glm fits with a warning.
staircases <- read.csv("psychometric_staircases.csv", comment.char = "#",
                       stringsAsFactors = FALSE)
staircases$disc_fraction <- number(staircases$disc_fraction)
write_reference(
  staircases, "psychometric_staircases.csv",
  paste("staircases of a simulated study (glarelab run spencer1995 --simulate --participants",
        "42 --seed 7): a sample of its 1008, those without a psychometric match, steep ones and",
        "others, then five made by hand; y: glare brighter 1, disc brighter 0, neither 0.5")
)
staircases <- read.csv("psychometric_staircases.csv", comment.char = "#",
                       stringsAsFactors = FALSE)
rows <- list()
for (name in unique(staircases$staircase)) {
  s <- staircases[staircases$staircase == name, ]
  warned <- FALSE
  fit <- withCallingHandlers(
    glm(y ~ disc_fraction, family = binomial, data = s,
        control = glm.control(epsilon = 1e-14, maxit = 200)),
    warning = function(w) {
      if (grepl("fitted probabilities numerically 0 or 1", conditionMessage(w))) warned <<- TRUE
      invokeRestart("muffleWarning")
    }
  )
  b <- coef(fit)
  rows[[length(rows) + 1]] <- data.frame(
    staircase = name, trials = nrow(s), b0 = number(b[1]), b1 = number(b[2]),
    centre = number(-b[1] / b[2]),
    lr_p = number(pchisq(fit$null.deviance - fit$deviance, 1, lower.tail = FALSE)),
    converged = fit$converged, fitted_0_or_1 = warned
  )
}
write_reference(
  do.call(rbind, rows), "psychometric_glm.csv",
  paste("glm(y ~ disc_fraction, family = binomial, control = glm.control(epsilon = 1e-14,",
        "maxit = 200)); centre = -b0 / b1; lr_p: the likelihood-ratio test of b1 = 0;",
        "fitted_0_or_1: glm warned 'fitted probabilities numerically 0 or 1' (separation)")
)
