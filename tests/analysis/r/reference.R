# Reference values for microg.analysis, computed with R's afex, emmeans and stats.
#
#   Rscript reference.R mixed DATA.csv DV WITHIN BETWEEN SUBJECT SS_TYPE OUT_PREFIX
#     afex::aov_ez (type SS_TYPE, Greenhouse-Geisser) -> OUT_PREFIX_anova.csv
#     emmeans on afex's multivariate model, Bonferroni -> OUT_PREFIX_posthoc.csv
#   Rscript reference.R study TRIALS.csv QUESTIONNAIRE.csv SYSTEM BASELINE OUT_DIR
#     the whole analysis of a study export, following the rules in docs/analysis.md:
#     anova_<measure>_<system>.csv, posthoc_<measure>_<system>.csv, systems.csv,
#     likert_summary.csv, likert_tests.csv
# Factor levels are R's sorted levels; contrasts are "A - B" in that order.
suppressMessages({
  library(afex)
  library(emmeans)
})

mixed_reference <- function(d, dv, within, between, subject, ss_type) {
  d[[within]] <- factor(d[[within]])
  d[[between]] <- factor(d[[between]])
  d[[subject]] <- factor(d[[subject]])
  fit <- suppressWarnings(suppressMessages(aov_ez(
    id = subject, dv = dv, data = d, between = between, within = within, type = ss_type)))
  uni <- suppressWarnings(summary(fit$Anova, multivariate = FALSE))
  tests <- as.data.frame(unclass(uni$univariate.tests))
  tests <- tests[rownames(tests) != "(Intercept)", ]
  sources <- rownames(tests)
  lookup <- function(table, column) {
    if (is.null(table)) return(rep(NA, length(sources)))
    table <- as.data.frame(unclass(table))
    ifelse(sources %in% rownames(table), table[sources, column], NA)
  }
  anova <- data.frame(
    source = sources,
    SS = tests[["Sum Sq"]],
    df1 = tests[["num Df"]],
    df2 = tests[["den Df"]],
    SS_error = tests[["Error SS"]],
    F = tests[["F value"]],
    p_unc = tests[["Pr(>F)"]],
    np2 = tests[["Sum Sq"]] / (tests[["Sum Sq"]] + tests[["Error SS"]]),
    eps_GG = lookup(uni$pval.adjustments, "GG eps"),
    p_GG = lookup(uni$pval.adjustments, "Pr(>F[GG])"),
    W_mauchly = lookup(uni$sphericity.tests, "Test statistic"),
    p_mauchly = lookup(uni$sphericity.tests, "p-value")
  )
  tidy_pairs <- function(prs, family) {
    unadj <- as.data.frame(summary(prs, by = NULL, adjust = "none"))
    adj <- as.data.frame(summary(prs, by = NULL, adjust = "bonferroni"))
    levels <- strsplit(as.character(unadj$contrast), " - ", fixed = TRUE)
    data.frame(
      factor = family,
      at = if (family == between) as.character(unadj[[within]]) else NA,
      A = sapply(levels, `[`, 1), B = sapply(levels, `[`, 2),
      estimate = unadj$estimate, SE = unadj$SE, df = unadj$df, T = unadj$t.ratio,
      p_unc = unadj$p.value, p_bonf = adj$p.value
    )
  }
  posthoc <- rbind(
    tidy_pairs(pairs(emmeans(fit, as.formula(paste("~", within)))), within),
    tidy_pairs(pairs(emmeans(fit, as.formula(paste("~", between, "|", within)))), between)
  )
  list(anova = anova, posthoc = posthoc)
}

signed_rank <- function(x, y) {
  test <- suppressWarnings(wilcox.test(x, y, paired = TRUE))
  d <- x - y
  d <- d[d != 0]
  n <- length(d)
  ranks <- rank(abs(d))
  v_plus <- sum(ranks[d > 0])
  v_minus <- sum(ranks[d < 0])
  ties <- table(ranks)
  z <- (v_plus - n * (n + 1) / 4) / sqrt(n * (n + 1) * (2 * n + 1) / 24 - sum(ties^3 - ties) / 48)
  list(V = unname(test$statistic), p = test$p.value, z = z, r = z / sqrt(n),
       rbc = (v_plus - v_minus) / (v_plus + v_minus))
}

study_reference <- function(trials_file, answers_file, system, baseline, out) {
  trials <- read.csv(trials_file, stringsAsFactors = FALSE)
  trials <- trials[tolower(trials$stage) != "training", ]
  # time: completed tasks only; attempts: every task with a count; one value per cell = the mean
  rows <- list(time_s = trials[trials$completed %in% c(TRUE, "True", "true"), ],
               attempts = trials[!is.na(trials$attempts), ])
  cells <- lapply(names(rows), function(dv) {
    r <- rows[[dv]]
    aggregate(r[dv], by = r[c("participant", "group", "system", "object")], FUN = mean)
  })
  names(cells) <- names(rows)
  objects <- sort(unique(trials$object))
  systems <- list()
  for (dv in names(cells)) {
    for (s in sort(unique(trials$system))) {
      res <- mixed_reference(cells[[dv]][cells[[dv]]$system == s, ], dv, "object", "group", "participant", 3)
      write.csv(res$anova, file.path(out, paste0("anova_", dv, "_", s, ".csv")), row.names = FALSE)
      write.csv(res$posthoc, file.path(out, paste0("posthoc_", dv, "_", s, ".csv")), row.names = FALSE)
    }
    means <- lapply(c(system, baseline), function(s) {
      c1 <- cells[[dv]][cells[[dv]]$system == s, ]
      counts <- table(c1$participant)
      c1 <- c1[c1$participant %in% names(counts)[counts == length(objects)], ]
      tapply(c1[[dv]], c1$participant, mean)
    })
    ids <- sort(intersect(names(means[[1]]), names(means[[2]])))
    x <- as.numeric(means[[1]][ids]); y <- as.numeric(means[[2]][ids])
    tt <- t.test(x, y, paired = TRUE)
    sr <- signed_rank(x, y)
    systems[[dv]] <- data.frame(
      measure = dv, system = system, baseline = baseline, n = length(ids),
      mean_system = mean(x), sd_system = sd(x), mean_baseline = mean(y), sd_baseline = sd(y),
      mean_diff = mean(x - y), T = unname(tt$statistic), dof = unname(tt$parameter), p_t = tt$p.value,
      cohen_d = mean(x - y) / sqrt((var(x) + var(y)) / 2),
      V = sr$V, p_wilcoxon = sr$p, rbc = sr$rbc, p_shapiro = shapiro.test(x - y)$p.value)
  }
  write.csv(do.call(rbind, systems), file.path(out, "systems.csv"), row.names = FALSE)

  answers <- read.csv(answers_file, stringsAsFactors = FALSE)
  summary_rows <- list(); test_rows <- list()
  for (item in sort(unique(answers$item))) {
    for (s in sort(unique(answers$system))) {
      r <- answers$rating[answers$item == item & answers$system == s]
      q <- quantile(r, c(0.25, 0.5, 0.75), type = 7)
      summary_rows[[length(summary_rows) + 1]] <- data.frame(
        item = item, system = s, n = length(r), median = median(r), q1 = q[[1]], q3 = q[[3]],
        mean = mean(r), t(sapply(0:10, function(v) sum(r == v))))
    }
    a <- answers[answers$item == item, ]
    x <- a[a$system == system, c("participant", "rating")]
    y <- a[a$system == baseline, c("participant", "rating")]
    pairs <- merge(x, y, by = "participant", suffixes = c("_system", "_baseline"))
    sr <- signed_rank(pairs$rating_system, pairs$rating_baseline)
    test_rows[[item]] <- data.frame(item = item, n = nrow(pairs), V = sr$V, p_unc = sr$p,
                                    z = sr$z, r = sr$r, rbc = sr$rbc)
  }
  likert_summary <- do.call(rbind, summary_rows)
  names(likert_summary)[8:18] <- paste0("count_", 0:10)
  write.csv(likert_summary, file.path(out, "likert_summary.csv"), row.names = FALSE)
  tests <- do.call(rbind, test_rows)
  tests$p_bonf <- p.adjust(tests$p_unc, method = "bonferroni")
  write.csv(tests, file.path(out, "likert_tests.csv"), row.names = FALSE)
}

args <- commandArgs(trailingOnly = TRUE)
if (length(args) == 8 && args[1] == "mixed") {
  res <- mixed_reference(read.csv(args[2], stringsAsFactors = FALSE), args[3], args[4], args[5], args[6],
                         as.integer(args[7]))
  write.csv(res$anova, paste0(args[8], "_anova.csv"), row.names = FALSE)
  write.csv(res$posthoc, paste0(args[8], "_posthoc.csv"), row.names = FALSE)
} else if (length(args) == 6 && args[1] == "study") {
  study_reference(args[2], args[3], args[4], args[5], args[6])
} else {
  stop("usage: reference.R mixed DATA DV WITHIN BETWEEN SUBJECT SS_TYPE OUT_PREFIX | ",
       "reference.R study TRIALS QUESTIONNAIRE SYSTEM BASELINE OUT_DIR")
}
