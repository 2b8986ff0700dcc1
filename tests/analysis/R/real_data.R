# Reference values for the analyses of data a lab gets and simulated observers rarely make,
# computed in R. The tests (tests/analysis/test_real_data.py) compare against the CSV files this
# script writes next to itself; they do not need R.
#
#   cd tests/analysis/R && Rscript real_data.R
#
# Every file starts with comment lines naming the R version and the packages that made it.
# Numbers are written with 17 significant digits, so they read back as the same doubles.
#
# The designs: matches at the display's maximum (two levels for every participant, and both
# methods alike at a compared level, and a constant difference at another), matches below the
# displayed disk (a negative boost), a one-way design whose Greenhouse-Geisser test and
# uncorrected test disagree, Spencer's 12 x 2 with 10 participants (sphericity not estimable),
# ratings whose median is the midpoint, and staircases whose intensities drifted in the last bits.

suppressPackageStartupMessages({
  library(car)
  library(afex)
  library(multcompView)
  library(emmeans)
  library(effectsize)
})

HEADER <- c(
  sprintf("# made by tests/analysis/R/real_data.R with %s", R.version.string),
  sprintf(
    "# packages: car %s, afex %s, multcompView %s, stats %s",
    packageVersion("car"), packageVersion("afex"), packageVersion("multcompView"),
    packageVersion("stats")
  ),
  sprintf("# and: emmeans %s, effectsize %s", packageVersion("emmeans"),
          packageVersion("effectsize"))
)

number <- function(x) ifelse(is.na(x), "NA", sprintf("%.17g", x))

write_reference <- function(table, file, note) {
  con <- file(file, "w")
  writeLines(c(HEADER, paste("#", note)), con)
  write.csv(table, con, row.names = FALSE, quote = TRUE, na = "NA")
  close(con)
}

ALPHA <- 0.05

# ------------------------------------------------------------------ helpers, independent of
# the Python code: the interval level that agrees with a Holm-corrected decision is found by
# root finding on p.adjust itself (the adjusted p of test i as its own p varies, the others
# fixed), not by the scan glarelab uses.
holm_level <- function(p, i, alpha = ALPHA) {
  if (is.na(p[i])) return(NA)
  adjusted <- function(x) { q <- p; q[i] <- x; p.adjust(q, "holm")[i] - alpha }
  if (adjusted(1) < 0) return(0)  # never rejected... only with alpha >= 1
  if (adjusted(.Machine$double.xmin) >= 0) return(1)
  1 - uniroot(adjusted, c(.Machine$double.xmin, 1), tol = 1e-15)$root
}
holm_levels <- function(p) sapply(seq_along(p), function(i) holm_level(p, i))

# a t.test that gives NA where R stops ("data are essentially constant") or gives NaN
tested <- function(...) {
  result <- tryCatch(t.test(...), error = function(e) e)
  if (inherits(result, "error")) {
    return(list(t = NA, df = NA, p = NA, low = NA, high = NA, estimate = NA,
                why = conditionMessage(result)))
  }
  list(t = unname(result$statistic), df = unname(result$parameter), p = result$p.value,
       low = result$conf.int[1], high = result$conf.int[2],
       estimate = unname(result$estimate[1]), why = if (is.nan(result$p.value)) "NaN" else "")
}

nct_root <- function(t, df, probability) {
  uniroot(function(x) pt(t, df, ncp = x) - probability, t + c(-1, 1) * (abs(t) + 50),
          tol = 1e-15)$root
}
dz_interval <- function(d, level) {
  n <- length(d)
  t <- mean(d) / (sd(d) / sqrt(n))
  c(nct_root(t, n - 1, (1 + level) / 2), nct_root(t, n - 1, (1 - level) / 2)) / sqrt(n)
}

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

# the ANOVA as afex computes it, with car's corrections, the lower bound and the eta2p interval
# from the df of the test each effect is decided on (GG below .75, HF above, LB where car
# finds the error matrix singular)
anova_rows <- function(data, within, design, subject = "subject") {
  formula <- as.formula(sprintf(
    "y ~ %s + Error(%s / (%s))", paste(within, collapse = " * "), subject,
    paste(within, collapse = " * ")
  ))
  fit <- suppressWarnings(suppressMessages(aov_car(formula, data = data)))
  tests <- suppressWarnings(summary(fit$Anova, multivariate = FALSE))
  univariate <- tests$univariate.tests
  table <- anova(fit, es = c("ges", "pes"), correction = "none")
  rows <- list()
  for (effect in setdiff(rownames(univariate), "(Intercept)")) {
    df1 <- univariate[effect, "num Df"]
    df2 <- univariate[effect, "den Df"]
    f <- univariate[effect, "F value"]
    singular <- fit$Anova$singular[[effect]]
    corrections <- tests$pval.adjustments
    has <- !singular && df1 > 1 && effect %in% rownames(corrections)
    eps_gg <- if (has) corrections[effect, "GG eps"] else NA
    eps_hf <- if (has) min(1, corrections[effect, "HF eps"]) else NA
    chosen <- if (df1 <= 1) "none" else if (singular || !has) "LB" else
      if (eps_gg < 0.75) "GG" else "HF"
    eps <- switch(chosen, none = 1, LB = 1 / df1, GG = eps_gg, HF = eps_hf)
    p_chosen <- pf(f, df1 * eps, df2 * eps, lower.tail = FALSE)
    ci <- eta2_ci(f, df1 * eps, df2 * eps)
    es <- F_to_eta2(f, df1 * eps, df2 * eps, ci = 0.90, alternative = "two.sided")
    rows[[length(rows) + 1]] <- data.frame(
      design = design, source = effect, df1 = number(df1), df2 = number(df2), F = number(f),
      MSE = number(table[effect, "MSE"]), p = number(univariate[effect, "Pr(>F)"]),
      singular = singular, eps_gg = number(eps_gg), eps_hf = number(eps_hf),
      p_lb = number(pf(f, 1, df2 / df1, lower.tail = FALSE)), correction = chosen,
      p_decided = number(p_chosen), eta2_partial = number(table[effect, "pes"]),
      eta2_generalized = number(table[effect, "ges"]),
      eta2p_ci_low = number(ci[1]), eta2p_ci_high = number(ci[2]),
      effectsize_ci_low = number(es$CI_low), effectsize_ci_high = number(es$CI_high)
    )
  }
  do.call(rbind, rows)
}

# ------------------------------------------------------------------ matching designs
# 10 participants, Yoshida's 6 levels x 2 methods (gaussian, vos; L_disk as yoshida2008.toml),
# on its display of 433 cd/m^2, the disk shown at min(L_disk, L_dmax = 220)
L_DISK <- list(gaussian = c(220, 1165, 2110, 3055, 4000, 7000),
               vos = c(220, 1480, 2740, 4000, 7000, 10000))
L_DMAX <- 220
MAXIMUM <- 423  # the brightest setting the participants could make

matching <- function(seed, top) {
  set.seed(seed)
  rows <- list()
  for (s in 1:10) {
    person <- rnorm(1, 0, 15)
    for (method in names(L_DISK)) {
      for (k in 1:6) {
        shown <- min(L_DISK[[method]][k], L_DMAX)
        match <- round(top(shown, k, method, person), 1)
        rows[[length(rows) + 1]] <- data.frame(
          participant = sprintf("p%02d", s), method = method, level_index = k,
          l_disk_cd_m2 = L_DISK[[method]][k], match_cd_m2 = match
        )
      }
    }
  }
  do.call(rbind, rows)
}

DESIGNS <- list(
  # every participant at the maximum at E/e and F/f (both methods alike there)
  saturated = function() matching(101, function(shown, k, method, person) {
    if (k >= 5) return(MAXIMUM)
    min(MAXIMUM, shown * (1 + 0.1 * k) + person + rnorm(1, if (method == "vos") -8 else 0, 12))
  }),
  # both methods set alike by every participant at D/d (a difference of 0 each), a constant
  # difference of 20 cd/m^2 between the vos levels e and f, and matches below the displayed
  # disk at the highest level (a negative boost)
  constant_and_negative = function() {
    data <- matching(102, function(shown, k, method, person) {
      if (k == 6) return(shown * 0.85 + person / 3 + rnorm(1, 0, 6))
      shown * (1 + 0.08 * k) + person + rnorm(1, 0, 10)
    })
    d <- data$level_index == 4
    data$match_cd_m2[d & data$method == "vos"] <- data$match_cd_m2[d & data$method == "gaussian"]
    e <- data$method == "vos" & data$level_index == 5
    f <- data$method == "vos" & data$level_index == 6
    data$match_cd_m2[f] <- data$match_cd_m2[e] - 20
    data
  }
)

anovas <- list()
compared <- list()
contrasts <- list()
boosts <- list()
FOLLOWUPS <- list("6 x 2 (all levels)" = 1:6, "3 x 2 ({A, B, C})" = 1:3, "3 x 2 ({D, E, F})" = 4:6)
for (name in names(DESIGNS)) {
  data <- DESIGNS[[name]]()
  file <- sprintf("real_matching_%s.csv", name)
  write_reference(data, file, sprintf("matching design %s: one row per participant, method, level", name))
  data <- read.csv(file, comment.char = "#", stringsAsFactors = FALSE)
  long <- data.frame(subject = data$participant, L_disk = factor(data$level_index),
                     method = data$method, y = data$match_cd_m2)
  for (analysis in names(FOLLOWUPS)) {
    part <- long[long$L_disk %in% FOLLOWUPS[[analysis]], ]
    part$L_disk <- droplevels(part$L_disk)
    rows <- anova_rows(part, c("L_disk", "method"), name)
    rows$analysis <- analysis
    anovas[[length(anovas) + 1]] <- rows
  }
  # the methods compared at D, E, F: paired (Holm over the computable ones) and Welch
  wide <- reshape(data[, c("participant", "method", "level_index", "match_cd_m2")],
                  idvar = "participant", timevar = "method", direction = "wide",
                  v.names = "match_cd_m2", sep = ".")
  rows <- list()
  for (k in 4:6) {
    a <- data$match_cd_m2[data$method == "gaussian" & data$level_index == k]
    b <- data$match_cd_m2[data$method == "vos" & data$level_index == k]
    paired <- tested(a, b, paired = TRUE)
    welch <- tested(a, b)
    rows[[length(rows) + 1]] <- data.frame(
      design = name, level_index = k, paired_t = paired$t, paired_p = paired$p,
      paired_why = paired$why, welch_t = welch$t, welch_df = welch$df, welch_p = welch$p,
      welch_low = welch$low, welch_high = welch$high, welch_why = welch$why,
      mean_difference = mean(a - b)
    )
  }
  table <- do.call(rbind, rows)
  table$p_holm <- p.adjust(table$paired_p, "holm")
  table$level <- holm_levels(table$paired_p)
  table$md_ci_low <- NA
  table$md_ci_high <- NA
  table$dz_ci_low <- NA
  table$dz_ci_high <- NA
  for (j in which(!is.na(table$paired_p))) {
    k <- table$level_index[j]
    a <- data$match_cd_m2[data$method == "gaussian" & data$level_index == k]
    b <- data$match_cd_m2[data$method == "vos" & data$level_index == k]
    ci <- t.test(a, b, paired = TRUE, conf.level = table$level[j])$conf.int
    dz <- dz_interval(a - b, table$level[j])
    table[j, c("md_ci_low", "md_ci_high", "dz_ci_low", "dz_ci_high")] <- c(ci, dz)
  }
  compared[[length(compared) + 1]] <- table
  # the levels of each method compared pairwise: Holm over the pairs R can test
  for (method in names(L_DISK)) {
    part <- data[data$method == method, ]
    pairs <- combn(1:6, 2)
    rows <- list()
    for (j in seq_len(ncol(pairs))) {
      a <- part$match_cd_m2[part$level_index == pairs[1, j]]
      b <- part$match_cd_m2[part$level_index == pairs[2, j]]
      test <- tested(a, b, paired = TRUE)
      rows[[j]] <- data.frame(design = name, method = method, a = pairs[1, j],
                              b = pairs[2, j], t = test$t, p = test$p, why = test$why)
    }
    table <- do.call(rbind, rows)
    table$p[is.nan(table$p)] <- NA
    table$p_holm <- p.adjust(table$p, "holm")
    table$level <- holm_levels(table$p)
    table$md_ci_low <- NA
    table$md_ci_high <- NA
    table$dz_ci_low <- NA
    table$dz_ci_high <- NA
    for (j in which(!is.na(table$p))) {
      a <- part$match_cd_m2[part$level_index == table$a[j]]
      b <- part$match_cd_m2[part$level_index == table$b[j]]
      ci <- t.test(a, b, paired = TRUE, conf.level = table$level[j])$conf.int
      table[j, c("md_ci_low", "md_ci_high", "dz_ci_low", "dz_ci_high")] <-
        c(ci, dz_interval(a - b, table$level[j]))
    }
    letters <- multcompLetters(
      setNames(ifelse(is.na(table$p_holm), 1, table$p_holm), paste(table$a, table$b, sep = "-")),
      threshold = ALPHA
    )$Letters
    table$letters_a <- unname(letters[as.character(table$a)])
    table$letters_b <- unname(letters[as.character(table$b)])
    contrasts[[length(contrasts) + 1]] <- table
  }
  # the boost at each method's highest level against 0 (Holm over the methods)
  rows <- list()
  for (method in names(L_DISK)) {
    top <- data[data$method == method & data$level_index == 6, ]
    shown <- pmin(top$l_disk_cd_m2, L_DMAX)
    boost <- (top$match_cd_m2 - shown) / shown * 100
    test <- tested(boost)
    rows[[length(rows) + 1]] <- data.frame(design = name, method = method, t = test$t,
                                           df = test$df, p = test$p, mean = mean(boost),
                                           why = test$why)
  }
  table <- do.call(rbind, rows)
  table$p_holm <- p.adjust(table$p, "holm")
  table$level <- holm_levels(table$p)
  table$ci_low <- NA
  table$ci_high <- NA
  for (j in which(!is.na(table$p))) {
    top <- data[data$method == table$method[j] & data$level_index == 6, ]
    shown <- pmin(top$l_disk_cd_m2, L_DMAX)
    table[j, c("ci_low", "ci_high")] <-
      t.test((top$match_cd_m2 - shown) / shown * 100, conf.level = table$level[j])$conf.int
  }
  boosts[[length(boosts) + 1]] <- table
}
numbers <- function(table) {
  for (column in names(table)) if (is.numeric(table[[column]])) table[[column]] <- number(table[[column]])
  table
}
write_reference(
  do.call(rbind, anovas), "real_matching_anova.csv",
  paste("afex::aov_car and summary(car::Anova, multivariate = FALSE) per analysis; MSE: afex's;",
        "correction: GG (eps < .75), HF, LB (car: singular), none (1 df); p_decided with it;",
        "eta2p_ci from its df (uniroot), effectsize_ci: F_to_eta2 with the same df")
)
write_reference(
  numbers(do.call(rbind, compared)), "real_matching_methods.csv",
  paste("gaussian vs vos at each level: t.test(paired = TRUE) and t.test (Welch), NA where R",
        "stops ('data are essentially constant') or gives NaN; p.adjust('holm') of the paired;",
        "level: 1 - the p at which the Holm-adjusted p reaches .05 (uniroot on p.adjust);",
        "md_ci: t.test(conf.level = level); dz_ci: noncentral t at that level (uniroot)")
)
write_reference(
  numbers(do.call(rbind, contrasts)), "real_matching_contrasts.csv",
  paste("every pair of levels per method: t.test(paired = TRUE), NA where R cannot test,",
        "p.adjust('holm') without them; intervals at the Holm-compatible level as above;",
        "multcompLetters(p_holm, NA as 1)")
)
write_reference(
  numbers(do.call(rbind, boosts)), "real_matching_boost.csv",
  paste("the boost (match - min(L_disk, 220)) / min(L_disk, 220) * 100 at level 6:",
        "t.test(boost), p.adjust('holm') over the methods, conf.int at the Holm-compatible level")
)

# ------------------------------------------------------------------ corrected vs uncorrected
# A one-way design of 5 levels whose variance grows with the level: the first seed whose
# uncorrected test is significant and whose Greenhouse-Geisser test is not.
make_oneway <- function(seed) {
  set.seed(seed)
  grid <- expand.grid(subject = sprintf("S%02d", 1:8), cue = sprintf("L%d", 1:5),
                      stringsAsFactors = FALSE)
  level <- match(grid$cue, sprintf("L%d", 1:5))
  grid$y <- round(rnorm(8)[match(grid$subject, sprintf("S%02d", 1:8))] + 0.35 * level +
                    rnorm(nrow(grid), 0, 0.2 + 0.9 * (level - 1)^1.5), 4)
  grid
}
for (seed in 1:500) {
  data <- make_oneway(seed)
  rows <- anova_rows(data, "cue", "disagree")
  if (as.numeric(rows$p) < ALPHA && as.numeric(rows$p_decided) >= ALPHA) break
}
write_reference(data, "real_disagree_data.csv",
                sprintf("one-way, 5 levels, 8 subjects, variance growing with the level (seed %d)", seed))
data <- read.csv("real_disagree_data.csv", comment.char = "#", stringsAsFactors = FALSE)
disagree <- anova_rows(data, "cue", "disagree")

# Spencer's shape with 10 participants: 11 df, sphericity not estimable; the lower bound
# decides (the design of reference.R's spencer_12x2 with two more subjects)
source_design <- function(factors, n, seed, spread = 0.6, slope = 0.3) {
  set.seed(seed)
  levels <- lapply(factors, function(k) sprintf("L%d", seq_len(k)))
  grid <- expand.grid(c(list(.s = seq_len(n)), levels), stringsAsFactors = FALSE)
  intercept <- rnorm(n)
  slopes <- matrix(rnorm(n * length(factors), slope, abs(slope)), n)
  index <- sapply(names(factors), function(f) match(grid[[f]], levels[[f]]))
  index <- matrix(index, nrow(grid))
  mean <- intercept[grid$.s] + rowSums(slopes[grid$.s, , drop = FALSE] * index) * 0.15
  y <- mean + rnorm(nrow(grid), 0, 1 + spread * (index[, 1] - 1))
  data <- data.frame(sprintf("S%02d", grid$.s), grid[names(factors)], round(y, 4))
  names(data) <- c("subject", names(factors), "y")
  data[order(data$subject), ]
}
# the first seed where the lower bound reverses the uncorrected decision of glare level
for (seed in 1:500) {
  data <- source_design(c(glare_level = 12, context = 2), 10, seed)
  rows <- anova_rows(data, c("glare_level", "context"), "spencer_10")
  if (as.numeric(rows$p[1]) < ALPHA && as.numeric(rows$p_lb[1]) >= ALPHA) break
}
write_reference(data, "real_spencer_10.csv",
                sprintf("12 x 2, 10 subjects: long format (seed %d)", seed))
data <- read.csv("real_spencer_10.csv", comment.char = "#", stringsAsFactors = FALSE)
spencer <- anova_rows(data, c("glare_level", "context"), "spencer_10")
write_reference(
  rbind(disagree, spencer), "real_anova.csv",
  paste("as real_matching_anova.csv: the one-way design whose GG and uncorrected tests",
        "disagree, and 12 x 2 with 10 subjects (LB where car finds the error matrix singular)")
)

# ------------------------------------------------------------------ ratings at the midpoint
RATINGS <- list(
  # the median at the midpoint, every other rating above it
  above_at_median = c(rep(4, 13), rep(5, 12)),
  # and every other rating below it
  below_at_median = c(rep(4, 13), rep(3, 12)),
  spread = c(7, 5, 3, 6, 6, 6, 6, 4, 5, 6, 2, 7, 5, 6, 4, 5, 6, 6, 3, 5, 6, 7, 4, 5, 6),
  midpoint = rep(4, 25)
)
p <- sapply(RATINGS, function(x) suppressWarnings(wilcox.test(x, mu = 4))$p.value)
p[is.nan(p)] <- NA
levels <- holm_levels(p)
rows <- list()
for (j in seq_along(RATINGS)) {
  x <- RATINGS[[j]]
  test <- suppressWarnings(wilcox.test(x, mu = 4, conf.int = !is.na(p[j]),
                                       conf.level = if (is.na(levels[j])) 0.95 else levels[j]))
  rb <- if (is.na(p[j])) list(r_rank_biserial = NA, CI_low = NA, CI_high = NA) else
    rank_biserial(x, mu = 4, ci = 0.95)
  rows[[j]] <- data.frame(
    category = names(RATINGS)[j], ratings = paste(x, collapse = ";"),
    V = number(unname(test$statistic)), p = number(p[j]),
    p_holm = number(p.adjust(p, "holm")[j]), level = number(levels[j]),
    estimate = number(if (is.na(p[j])) NA else unname(test$estimate)),
    ci_low = number(if (is.na(p[j])) NA else test$conf.int[1]),
    ci_high = number(if (is.na(p[j])) NA else test$conf.int[2]),
    conf_level = number(if (is.na(p[j])) NA else attr(test$conf.int, "conf.level")),
    r_rb = number(rb$r_rank_biserial), rb_ci_low = number(rb$CI_low),
    rb_ci_high = number(rb$CI_high)
  )
}
write_reference(
  do.call(rbind, rows), "real_ratings.csv",
  paste("wilcox.test(x, mu = 4, conf.int = TRUE, conf.level = level), level: the",
        "Holm-compatible level (uniroot on p.adjust over the categories R can test);",
        "estimate and conf.int as R reports them (conf_level: the level R reached);",
        "effectsize::rank_biserial(x, mu = 4)")
)

# ------------------------------------------------------------------ drifting intensities
# Two staircases written with drifting intensities (sums of steps: 0.84 and
# 0.8400000000000001 are one intensity of the grid k / 50), fitted as written and on the grid.
STAIRCASES <- list(
  merged = data.frame(
    disc_fraction = c(0.9, 0.88, 0.8599999999999999, 0.8400000000000001, 0.86, 0.84,
                      0.8200000000000001, 0.84, 0.86, 0.8399999999999999, 0.82, 0.84),
    response = c("disc", "disc", "disc", "glare", "disc", "disc", "glare", "glare", "disc",
                 "disc", "glare", "glare")
  ),
  # answers that overlap over several intensities: a finite maximum, the same on the grid
  noisy = data.frame(
    disc_fraction = c(0.9, 0.86, 0.8200000000000001, 0.78, 0.8200000000000001, 0.86,
                      0.8399999999999999, 0.8, 0.84, 0.8600000000000001, 0.82, 0.78, 0.8, 0.84,
                      0.7799999999999999, 0.8799999999999999),
    response = c("disc", "disc", "glare", "glare", "disc", "glare", "disc", "glare", "glare",
                 "disc", "glare", "glare", "disc", "disc", "glare", "neither")
  ),
  overlap = data.frame(
    disc_fraction = c(0.8, 0.8200000000000001, 0.84, 0.8599999999999999, 0.88, 0.86,
                      0.8400000000000001, 0.82, 0.8399999999999999, 0.86),
    response = c("glare", "glare", "glare", "disc", "disc", "disc", "disc", "glare",
                 "glare", "disc")
  )
)
CODES <- c(glare = 1, disc = 0, neither = 0.5)
rows <- list()
points <- list()
for (name in names(STAIRCASES)) {
  s <- STAIRCASES[[name]]
  s$y <- unname(CODES[s$response])
  s$grid <- round(s$disc_fraction * 50) / 50
  points[[name]] <- data.frame(staircase = name, disc_fraction = number(s$disc_fraction),
                               response = s$response)
  for (scale in c("written", "grid")) {
    x <- if (scale == "grid") s$grid else s$disc_fraction
    warned <- FALSE
    fit <- withCallingHandlers(
      glm(s$y ~ x, family = binomial, control = glm.control(epsilon = 1e-14, maxit = 200)),
      warning = function(w) {
        if (grepl("fitted probabilities numerically 0 or 1", conditionMessage(w))) warned <<- TRUE
        invokeRestart("muffleWarning")
      }
    )
    b <- coef(fit)
    rows[[length(rows) + 1]] <- data.frame(
      staircase = name, scale = scale, distinct = length(unique(x)),
      b0 = number(b[1]), b1 = number(b[2]), centre = number(-b[1] / b[2]),
      converged = fit$converged, fitted_0_or_1 = warned,
      highest_glare = number(max(x[s$y > 0])), lowest_disc = number(min(x[s$y < 1]))
    )
  }
}
write_reference(do.call(rbind, points), "real_staircases.csv",
                "staircases written with drifting intensities (the grid: k / 50)")
write_reference(
  do.call(rbind, rows), "real_staircases_glm.csv",
  paste("glm(y ~ x, binomial, epsilon = 1e-14) on the intensities as written and on the grid",
        "(round(x * 50) / 50); fitted_0_or_1: glm warned of separation")
)
