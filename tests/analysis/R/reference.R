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
