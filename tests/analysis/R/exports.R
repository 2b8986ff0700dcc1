# R reads a glarelab report's CSVs as they are: the types of their columns, and a repeated-measures
# ANOVA on the per-participant wide table that gives the report's F.
#
#   Rscript exports.R REPORT_FOLDER [STUDY]
#
# Run by tests/analysis/test_exports.py (skipped where R is not installed). Stops with the
# problems found; prints "ok" and the checks made otherwise.

args <- commandArgs(trailingOnly = TRUE)
if (length(args) < 1) stop("usage: Rscript exports.R REPORT_FOLDER [STUDY]")
folder <- args[1]
study <- if (length(args) > 1) args[2] else ""
problems <- character()
checks <- character()
problem <- function(...) problems <<- c(problems, sprintf(...))

raw <- function(file) read.csv(file, colClasses = "character", check.names = FALSE, na.strings = "")
typed <- function(file) read.csv(file, check.names = FALSE, stringsAsFactors = FALSE)

# every CSV: a column of booleans reads as logical, a column of numbers as numeric
for (file in list.files(folder, pattern = "\\.csv$", full.names = TRUE)) {
  text <- raw(file)
  data <- typed(file)
  for (name in names(text)) {
    values <- text[[name]][!is.na(text[[name]])]
    if (length(values) == 0) next
    if (any(values %in% c("true", "false", "True", "False"))) {
      problem("%s, column %s: booleans written %s, which R reads as text", basename(file),
              name, values[values %in% c("true", "false", "True", "False")][1])
    }
    if (all(values %in% c("TRUE", "FALSE")) && !is.logical(data[[name]])) {
      problem("%s, column %s: TRUE/FALSE not read as logical (%s)", basename(file), name,
              class(data[[name]]))
    }
    numbers <- suppressWarnings(as.numeric(values))
    if (!any(is.na(numbers)) && !is.numeric(data[[name]])) {
      problem("%s, column %s: numbers read as %s", basename(file), name, class(data[[name]]))
    }
    if (!any(is.na(numbers)) && is.numeric(data[[name]])) {
      # the shortest text that gives the same double: one significant digit fewer does not
      # (4.6, not 4.5999999999999996)
      mantissa <- sub("[eE].*$", "", sub("^[-+]", "", values))
      digits <- nchar(sub("0+$", "", sub("^0+", "", gsub("\\.", "", mantissa))))
      finite <- is.finite(numbers) & digits > 1
      shorter <- mapply(function(x, n) as.numeric(sprintf("%.*g", n - 1L, x)),
                        numbers[finite], digits[finite])
      long <- values[finite][shorter == numbers[finite]]
      if (length(long)) {
        problem("%s, column %s: %s is written with more digits than its value needs",
                basename(file), name, long[1])
      }
    }
  }
  checks <- c(checks, sprintf("%s: %d columns typed", basename(file), ncol(data)))
}

trials <- typed(file.path(folder, "trials.csv"))
for (name in c("participant", "study", "block")) {
  if (!is.character(trials[[name]])) problem("trials.csv, column %s is not text", name)
}
for (name in c("trial", "session")) {
  if (!is.integer(trials[[name]])) problem("trials.csv, column %s is not integer", name)
}

wide <- file.path(folder, "participants_wide.csv")
if (file.exists(wide)) {
  wide <- typed(wide)
  cells <- setdiff(names(wide), "participant")
  if (anyDuplicated(wide$participant)) problem("participants_wide.csv: a participant twice")
  if (nrow(wide) != length(unique(trials$participant))) {
    problem("participants_wide.csv: %d rows for %d participants", nrow(wide),
            length(unique(trials$participant)))
  }
  for (name in cells) {
    if (!is.numeric(wide[[name]])) problem("participants_wide.csv, column %s is not numeric", name)
  }
  checks <- c(checks, sprintf("participants_wide.csv: %d participants x %d cells", nrow(wide),
                              length(cells)))
}

if (study == "yoshida2008" && is.data.frame(wide)) {
  # the wide table in a repeated-measures ANOVA (base R's aov with the participant's error
  # strata, as JASP's RM ANOVA computes it) gives the report's uncorrected F of each effect
  long <- reshape(wide, direction = "long", varying = cells, v.names = "match",
                  timevar = "cell", times = cells, idvar = "participant")
  parts <- do.call(rbind, strsplit(sub("^match_cd_m2_", "", long$cell), "_"))
  long$method <- factor(parts[, 1])
  long$L_disk <- factor(parts[, 2])
  long$participant <- factor(long$participant)
  fit <- summary(aov(match ~ L_disk * method + Error(participant / (L_disk * method)),
                     data = long))
  anova <- typed(file.path(folder, "anova.csv"))
  anova <- anova[anova$analysis == anova$analysis[1], ]
  strata <- c(L_disk = "Error: participant:L_disk", method = "Error: participant:method",
              "L_disk × method" = "Error: participant:L_disk:method")
  for (source in names(strata)) {
    table <- fit[[strata[[source]]]][[1]]
    f <- table[1, "F value"]
    reported <- anova$F[anova$source == source]
    if (length(reported) != 1 || abs(f - reported) > 1e-9 * max(1, abs(f))) {
      problem("F of %s: R's aov on participants_wide.csv gives %.10g, anova.csv says %s", source,
              f, paste(reported, collapse = ", "))
    }
    checks <- c(checks, sprintf("F(%s) = %.6g from the wide table, as anova.csv", source, f))
  }
}

if (length(problems)) {
  stop(paste(c("", problems), collapse = "\n  - "), call. = FALSE)
}
cat("ok\n", paste(checks, collapse = "\n"), "\n", sep = "")
