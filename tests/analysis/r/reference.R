# Reference values for microg.analysis, computed with R's afex, emmeans, car, rstatix, effectsize,
# geepack and stats.
#
#   Rscript reference.R mixed DATA.csv DV WITHIN BETWEEN SUBJECT SS_TYPE OUT_PREFIX
#     afex::aov_ez (type SS_TYPE) with generalised eta squared, Greenhouse-Geisser and Huynh-Feldt,
#     and the CI of partial eta squared -> OUT_PREFIX_anova.csv
#     emmeans on afex's multivariate model, Bonferroni, with CIs -> OUT_PREFIX_posthoc.csv
#     simple effects (emmeans joint_tests by BETWEEN) -> OUT_PREFIX_simple_effects.csv, their pairs
#     -> OUT_PREFIX_simple_pairs.csv; Levene, Box's M, Shapiro-Wilk of the residuals
#     -> OUT_PREFIX_assumptions.csv; mean, SD, SE, n per cell -> OUT_PREFIX_cell_means.csv
#     ARTool's aligned ranks: the ANOVA of the ranks (type 2: ARTool's own anova of
#     art(DV ~ BETWEEN * WITHIN + Error(SUBJECT)); type 3: afex on ARTool's ranks) -> OUT_PREFIX_art_anova.csv,
#     ART-C contrasts (ARTool's ranks for each term, emmeans on afex's model) -> OUT_PREFIX_art_contrasts.csv
#   Rscript reference.R study TRIALS.csv QUESTIONNAIRE.csv INTERACTION BASELINE OUT_DIR
#     the whole analysis of a study export, following the rules in docs/analysis.md:
#     <table>_<measure>_<interaction>.csv for each table above, count_model_attempts_<interaction>.csv
#     (geepack), interactions.csv, likert_summary.csv, likert_tests.csv; the ART of each questionnaire
#     item (group x interaction) -> art_anova_<item>.csv, art_contrasts_<item>.csv; the linear mixed
#     model of log completion time on every finished task (lme4/lmerTest) -> trial_model_<table>.csv;
#     the ART of each measure's cells (complete cases) -> art_anova_<measure>_<interaction>.csv ...
#   Rscript reference.R trials TRIALS.csv FIXED SLOPE OUT_PREFIX
#     the linear mixed model of log(time_s) ~ FIXED with a random intercept and slope of SLOPE per
#     participant (the intercept alone when singular) -> OUT_PREFIX{coefficients,anova,random}.csv
#   Rscript reference.R training TRIALS.csv OUT_DIR
#     a training program's section (microg.analysis.training, rules in its docstring): each
#     participant's power law of practice (nls, port) -> power_law.csv; the learning curves' mixed
#     model (lme4/lmerTest) -> practice_model_{coefficients,anova,random}.csv and group_curves.csv;
#     tasks to criterion per session and phase with a criterion (survival: survfit, conf.type "log",
#     quantile; survdiff) -> kaplan_meier.csv, medians.csv, logrank.csv; the test sessions' mixed
#     ANOVA (afex, emmeans) -> session_{anova,posthoc,cell_means}.csv, their mixed model ->
#     session_model_{coefficients,anova,random}.csv, retention minus post-test per group -> retention.csv
# Factor levels are R's sorted levels; contrasts are "A - B" in that order.
# Confidence intervals of partial eta squared and d_z are computed twice: by inverting R's
# noncentral F / t with uniroot (np2_ci_low ...; exact) and by effectsize (*_effectsize; its
# optimiser stops at about 1e-5 relative).
suppressMessages({
  library(ARTool)
  library(lmerTest)
  library(afex)
  library(emmeans)
  library(car)
  library(rstatix)
  library(effectsize)
  library(geepack)
  library(survival)
})

noncentral_root <- function(cdf, p, floor) {
  # the noncentrality where cdf (falling in it) equals p; floor when the root would be below it
  if (!is.na(floor) && cdf(floor) <= p) return(floor)
  low <- if (is.na(floor)) -1 else floor
  high <- 1
  while (cdf(low) < p) low <- low * 2
  while (cdf(high) > p) high <- high * 2
  uniroot(function(x) cdf(x) - p, c(low, high), tol = 1e-13)$root
}

eta2_ci <- function(f, df1, df2) {
  bounds <- sapply(c(0.975, 0.025), function(p) noncentral_root(function(x) pf(f, df1, df2, ncp = x), p, 0))
  bounds / (bounds + df2)
}

dz_ci <- function(t, n) {
  sapply(c(0.975, 0.025), function(p) noncentral_root(function(x) pt(t, n - 1, ncp = x), p, NA)) / sqrt(n)
}

rbc_ci <- function(rbc, n_nonzero) {
  # effectsize::rank_biserial's interval (Fisher z), for our rbc
  se <- sqrt((2 * n_nonzero^3 + 3 * n_nonzero^2 + n_nonzero) / 6) / ((n_nonzero^2 + n_nonzero) / 2)
  tanh(atanh(rbc) + c(-1, 1) * qnorm(0.975) * se)
}

mixed_reference <- function(d, dv, within, between, subject, ss_type) {
  # complete cases, as afex keeps them: the assumption checks and cell means describe the same data
  present <- table(d[[subject]][!is.na(d[[dv]])])
  d <- d[d[[subject]] %in% names(present)[present == length(unique(d[[within]]))], ]
  d[[within]] <- factor(d[[within]])
  d[[between]] <- factor(d[[between]])
  d[[subject]] <- factor(d[[subject]])
  fit <- suppressWarnings(suppressMessages(aov_ez(
    id = subject, dv = dv, data = d, between = between, within = within, type = ss_type,
    anova_table = list(es = "ges", correction = "none"))))
  uni <- suppressWarnings(summary(fit$Anova, multivariate = FALSE))
  tests <- as.data.frame(unclass(uni$univariate.tests))
  tests <- tests[rownames(tests) != "(Intercept)", ]
  sources <- rownames(tests)
  lookup <- function(table, column) {
    if (is.null(table)) return(rep(NA, length(sources)))
    table <- as.data.frame(unclass(table))
    ifelse(sources %in% rownames(table), table[sources, column], NA)
  }
  ci <- t(mapply(eta2_ci, tests[["F value"]], tests[["num Df"]], tests[["den Df"]]))
  ci_effectsize <- t(mapply(function(f, df1, df2) {
    e <- F_to_eta2(f, df1, df2, ci = 0.95, alternative = "two.sided")
    c(e$CI_low, e$CI_high)
  }, tests[["F value"]], tests[["num Df"]], tests[["den Df"]]))
  anova <- data.frame(
    source = sources,
    SS = tests[["Sum Sq"]],
    df1 = tests[["num Df"]],
    df2 = tests[["den Df"]],
    SS_error = tests[["Error SS"]],
    F = tests[["F value"]],
    p_unc = tests[["Pr(>F)"]],
    np2 = tests[["Sum Sq"]] / (tests[["Sum Sq"]] + tests[["Error SS"]]),
    ges = fit$anova_table[sources, "ges"],
    np2_ci_low = ci[, 1], np2_ci_high = ci[, 2],
    np2_ci_low_effectsize = ci_effectsize[, 1], np2_ci_high_effectsize = ci_effectsize[, 2],
    eps_GG = lookup(uni$pval.adjustments, "GG eps"),
    p_GG = lookup(uni$pval.adjustments, "Pr(>F[GG])"),
    eps_HF = lookup(uni$pval.adjustments, "HF eps"),
    p_HF = lookup(uni$pval.adjustments, "Pr(>F[HF])"),
    W_mauchly = lookup(uni$sphericity.tests, "Test statistic"),
    p_mauchly = lookup(uni$sphericity.tests, "p-value")
  )
  tidy_pairs <- function(prs, family, at) {
    unadj <- as.data.frame(summary(prs, by = NULL, adjust = "none", infer = TRUE))
    adj <- as.data.frame(summary(prs, by = NULL, adjust = "bonferroni", infer = TRUE))
    levels <- strsplit(as.character(unadj$contrast), " - ", fixed = TRUE)
    data.frame(
      factor = family,
      at = if (is.null(at)) NA else as.character(unadj[[at]]),
      A = sapply(levels, `[`, 1), B = sapply(levels, `[`, 2),
      estimate = unadj$estimate, SE = unadj$SE, df = unadj$df, T = unadj$t.ratio,
      p_unc = unadj$p.value, p_bonf = adj$p.value,
      ci_low = unadj$lower.CL, ci_high = unadj$upper.CL, ci_low_bonf = adj$lower.CL, ci_high_bonf = adj$upper.CL
    )
  }
  by <- function(a, b) as.formula(paste("~", a, "|", b))
  posthoc <- rbind(
    tidy_pairs(pairs(emmeans(fit, as.formula(paste("~", within)))), within, NULL),
    tidy_pairs(pairs(emmeans(fit, by(between, within))), between, within)
  )
  simple_pairs <- tidy_pairs(pairs(emmeans(fit, by(within, between))), within, between)
  joint <- as.data.frame(joint_tests(fit, by = between))
  simple_effects <- data.frame(
    effect = within, at = as.character(joint[[between]]), df1 = joint$df1, df2 = joint$df2,
    # joint_tests prints F rounded to 3 decimals; its p is exact, and so is the F it comes from
    F = qf(joint$p.value, joint$df1, joint$df2, lower.tail = FALSE),
    p_unc = joint$p.value, p_bonf = p.adjust(joint$p.value, method = "bonferroni"))
  levene <- do.call(rbind, lapply(levels(d[[within]]), function(level) {
    test <- leveneTest(as.formula(paste(dv, "~", between)), data = d[d[[within]] == level, ])
    data.frame(check = "Levene", at = level, statistic = test[1, "F value"], df1 = test[1, "Df"],
               df2 = test[2, "Df"], p = test[1, "Pr(>F)"])
  }))
  wide <- reshape(aggregate(d[dv], by = d[c(subject, between, within)], FUN = mean),
                  idvar = c(subject, between), timevar = within, direction = "wide")
  box <- box_m(wide[, -(1:2)], wide[[between]])
  shapiro <- shapiro.test(suppressMessages(residuals(fit)))
  assumptions <- rbind(
    levene,
    data.frame(check = "Box's M", at = "", statistic = box$statistic, df1 = box$parameter, df2 = NA, p = box$p.value),
    data.frame(check = "Shapiro-Wilk of residuals", at = "", statistic = unname(shapiro$statistic), df1 = NA,
               df2 = NA, p = shapiro$p.value))
  keyed <- aggregate(d[dv], by = d[c(subject, between, within)], FUN = mean)
  stats <- function(f) aggregate(keyed[dv], by = keyed[c(between, within)], FUN = f)
  cell_means <- data.frame(stats(length)[c(between, within)], n = stats(length)[[dv]], mean = stats(mean)[[dv]],
                           sd = stats(sd)[[dv]], se = stats(sd)[[dv]] / sqrt(stats(length)[[dv]]),
                           share_zero = stats(function(v) mean(v == 0))[[dv]])
  list(anova = anova, posthoc = posthoc, simple_effects = simple_effects, simple_pairs = simple_pairs,
       assumptions = assumptions, cell_means = cell_means)
}

count_reference <- function(tasks, dv, within, between, subject) {
  # Poisson GEE, exchangeable correlation within participant, sum-to-zero coding; robust Wald
  # chi-square per term from geepack's coefficients and sandwich covariance
  tasks <- tasks[order(tasks[[subject]]), ]
  tasks$id <- factor(tasks[[subject]])
  tasks$b <- factor(tasks[[between]])
  tasks$w <- factor(tasks[[within]])
  tasks$y <- tasks[[dv]]
  old <- options(contrasts = c("contr.sum", "contr.poly"))
  on.exit(options(old))
  fit <- geeglm(y ~ b * w, id = id, family = poisson, corstr = "exchangeable", data = tasks)
  coefs <- coef(fit)
  covariance <- vcov(fit)
  assign <- attr(model.matrix(fit), "assign")
  terms <- c(between, within, paste0(between, ":", within))
  do.call(rbind, lapply(1:3, function(term) {
    i <- which(assign == term)
    chi2 <- as.numeric(t(coefs[i]) %*% solve(covariance[i, i], coefs[i]))
    data.frame(term = terms[term], chi2 = chi2, df = length(i), p_unc = pchisq(chi2, length(i), lower.tail = FALSE),
               correlation = summary(fit)$corr[1, "Estimate"], n_tasks = nrow(tasks))
  }))
}

complete_cases <- function(d, dv, within, subject) {
  present <- table(d[[subject]][!is.na(d[[dv]])])
  d[d[[subject]] %in% names(present)[present == length(unique(d[[within]]))] & !is.na(d[[dv]]), ]
}

art_reference <- function(d, dv, within, between, subject, ss_type) {
  # ARTool's aligned ranks on the complete cases; the ranks' mixed ANOVA and ART-C contrasts
  d <- complete_cases(d, dv, within, subject)
  d <- aggregate(d[dv], by = d[c(subject, between, within)], FUN = mean)
  for (column in c(within, between, subject)) d[[column]] <- factor(d[[column]])
  model <- art(as.formula(paste(dv, "~", between, "*", within, "+ Error(", subject, ")")), data = d)
  terms <- c(between, within, paste0(between, ":", within))
  ranked_anova <- function(ranks, term) {
    d$.rank <- ranks
    fit <- suppressWarnings(suppressMessages(aov_ez(id = subject, dv = ".rank", data = d, between = between,
                                                    within = within, type = ss_type,
                                                    anova_table = list(correction = "none"))))
    list(fit = fit, row = as.data.frame(fit$anova_table)[term, ])
  }
  if (ss_type == 2) {  # ARTool's own ANOVA: the stratified (Error) model's sequential sums of squares
    a <- as.data.frame(anova(model))
    anova_table <- data.frame(source = a$Term, F = a$`F value`, df1 = a$Df, df2 = a$Df.res, p_unc = a$`Pr(>F)`)
  } else {
    anova_table <- do.call(rbind, lapply(terms, function(term) {
      row <- ranked_anova(model$aligned.ranks[[term]], term)$row
      data.frame(source = term, F = row$F, df1 = row$`num Df`, df2 = row$`den Df`, p_unc = row$`Pr(>F)`)
    }))
  }
  # ART-C: the crossed term's factors joined into one and aligned for it (ARTool's art.con)
  d$.cell <- factor(paste(d[[between]], d[[within]], sep = ","))
  joined <- art(as.formula(paste(dv, "~ .cell + Error(", subject, ")")), data = d)
  ranks <- list(model$aligned.ranks[[between]], model$aligned.ranks[[within]], joined$aligned.ranks$.cell)
  specs <- list(as.formula(paste("~", between)), as.formula(paste("~", within)),
                as.formula(paste("~", between, "*", within)))
  contrasts <- do.call(rbind, lapply(1:3, function(i) {
    emm <- emmeans(ranked_anova(ranks[[i]], terms[i])$fit, specs[[i]])
    grid <- as.data.frame(summary(emm))
    labels <- if (i == 3) paste(grid[[between]], grid[[within]], sep = ",") else as.character(grid[[c(between, within)[i]]])
    ordered <- sort(labels)
    pairs <- combn(length(ordered), 2)
    methods <- lapply(seq_len(ncol(pairs)), function(j) (labels == ordered[pairs[1, j]]) - (labels == ordered[pairs[2, j]]))
    names(methods) <- paste(ordered[pairs[1, ]], ordered[pairs[2, ]], sep = " - ")
    tests <- as.data.frame(summary(contrast(emm, method = methods), adjust = "none", infer = TRUE))
    data.frame(term = terms[i], A = ordered[pairs[1, ]], B = ordered[pairs[2, ]], estimate = tests$estimate,
               SE = tests$SE, df = tests$df, T = tests$t.ratio, p_unc = tests$p.value,
               p_bonf = p.adjust(tests$p.value, method = "bonferroni"))
  }))
  list(art_anova = anova_table, art_contrasts = contrasts)
}

trial_model_reference <- function(trials, fixed, slope, prefix) {
  # log completion time of every finished task: FIXED, a random intercept and slope of SLOPE per
  # participant, dropped to the intercept when singular (lme4's isSingular)
  rows <- trials[trials$completed %in% c(TRUE, "True", "true") & !is.na(trials$time_s), ]
  for (column in intersect(c("group", "object", "interaction", "participant"), names(rows))) {
    rows[[column]] <- factor(rows[[column]])
  }
  old <- options(contrasts = c("contr.sum", "contr.poly"))
  on.exit(options(old))
  control <- lmerControl(optimizer = "bobyqa", optCtrl = list(rhoend = 1e-12, maxfun = 1e5))
  fixed <- paste("log(time_s) ~", fixed)
  fit <- lmer(as.formula(paste0(fixed, " + (1 + ", slope, " | participant)")), data = rows, REML = TRUE,
              control = control)
  with_slope <- !isSingular(fit)
  if (!with_slope) fit <- lmer(as.formula(paste(fixed, "+ (1 | participant)")), data = rows, REML = TRUE,
                               control = control)
  write_model(fit, with_slope, nrow(rows), prefix)
}

write_model <- function(fit, with_slope, n_trials, prefix) {
  # lmerTest's coefficients and type 3 F tests, and the random effects -> PREFIX{coefficients,anova,random}.csv
  coefficients <- as.data.frame(coef(summary(fit)))
  write.csv(data.frame(term = rownames(coefficients), estimate = coefficients$Estimate,
                       SE = coefficients$`Std. Error`, df = coefficients$df, t = coefficients$`t value`,
                       p_unc = coefficients$`Pr(>|t|)`),
            paste0(prefix, "coefficients.csv"), row.names = FALSE)
  a <- as.data.frame(anova(fit, type = 3))
  write.csv(data.frame(source = rownames(a), F = a$`F value`, df1 = a$NumDF, df2 = a$DenDF, p_unc = a$`Pr(>F)`),
            paste0(prefix, "anova.csv"), row.names = FALSE)
  random <- as.data.frame(VarCorr(fit))
  variances <- random[is.na(random$var2), ]
  write.csv(data.frame(slope = with_slope, n_trials = n_trials,
                       name = ifelse(variances$grp == "Residual", "Residual", paste(variances$grp, variances$var1)),
                       variance = variances$vcov, sd = variances$sdcor,
                       correlation = c(NA, random$sdcor[!is.na(random$var2)], NA)),
            paste0(prefix, "random.csv"), row.names = FALSE)
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
  rbc <- (v_plus - v_minus) / (v_plus + v_minus)
  ci <- rbc_ci(rbc, n)
  list(V = unname(test$statistic), p = test$p.value, z = z, r = z / sqrt(n), rbc = rbc, n_nonzero = n,
       rbc_ci_low = ci[1], rbc_ci_high = ci[2])
}

study_reference <- function(trials_file, answers_file, interaction, baseline, out) {
  trials <- read.csv(trials_file, stringsAsFactors = FALSE)
  trials <- trials[tolower(trials$phase) != "training", ]
  # time: completed tasks only; attempts: every task with a count; one value per cell = the mean
  rows <- list(time_s = trials[trials$completed %in% c(TRUE, "True", "true"), ],
               attempts = trials[!is.na(trials$attempts), ])
  cells <- lapply(names(rows), function(dv) {
    r <- rows[[dv]]
    aggregate(r[dv], by = r[c("participant", "group", "interaction", "object")], FUN = mean)
  })
  names(cells) <- names(rows)
  objects <- sort(unique(trials$object))
  interactions <- list()
  for (dv in names(cells)) {
    for (s in sort(unique(trials$interaction))) {
      c1 <- cells[[dv]][cells[[dv]]$interaction == s, ]
      res <- mixed_reference(c1, dv, "object", "group", "participant", 3)
      for (table in names(res)) {
        write.csv(res[[table]], file.path(out, paste0(table, "_", dv, "_", s, ".csv")), row.names = FALSE)
      }
      if (dv == "attempts") {
        counts <- table(c1$participant)
        complete <- names(counts)[counts == length(objects)]
        tasks <- rows[[dv]][rows[[dv]]$interaction == s & rows[[dv]]$participant %in% complete, ]
        write.csv(count_reference(tasks, dv, "object", "group", "participant"),
                  file.path(out, paste0("count_model_", dv, "_", s, ".csv")), row.names = FALSE)
      }
      # the ART of the cells, complete cases (this export has participants with a missing cell)
      art <- art_reference(c1, dv, "object", "group", "participant", 3)
      for (table in names(art)) {
        write.csv(art[[table]], file.path(out, paste0(table, "_", dv, "_", s, ".csv")), row.names = FALSE)
      }
    }
    means <- lapply(c(interaction, baseline), function(s) {
      c1 <- cells[[dv]][cells[[dv]]$interaction == s, ]
      counts <- table(c1$participant)
      c1 <- c1[c1$participant %in% names(counts)[counts == length(objects)], ]
      tapply(c1[[dv]], c1$participant, mean)
    })
    ids <- sort(intersect(names(means[[1]]), names(means[[2]])))
    x <- as.numeric(means[[1]][ids]); y <- as.numeric(means[[2]][ids])
    tt <- t.test(x, y, paired = TRUE)
    sr <- signed_rank(x, y)
    dz <- cohens_d(x, y, paired = TRUE, ci = 0.95)
    dz_interval <- dz_ci(unname(tt$statistic), length(ids))
    interactions[[dv]] <- data.frame(
      measure = dv, interaction = interaction, baseline = baseline, n = length(ids),
      mean_interaction = mean(x), sd_interaction = sd(x), mean_baseline = mean(y), sd_baseline = sd(y),
      mean_diff = mean(x - y), T = unname(tt$statistic), dof = unname(tt$parameter), p_t = tt$p.value,
      cohen_d = mean(x - y) / sqrt((var(x) + var(y)) / 2),
      V = sr$V, p_wilcoxon = sr$p, rbc = sr$rbc, p_shapiro = shapiro.test(x - y)$p.value,
      diff_ci_low = tt$conf.int[1], diff_ci_high = tt$conf.int[2],
      d_z = dz$Cohens_d, d_z_ci_low = dz_interval[1], d_z_ci_high = dz_interval[2],
      d_z_ci_low_effectsize = dz$CI_low, d_z_ci_high_effectsize = dz$CI_high,
      rbc_ci_low = sr$rbc_ci_low, rbc_ci_high = sr$rbc_ci_high, n_nonzero = sr$n_nonzero)
    if (all(x != y)) {  # effectsize ranks zero differences its own way; compare it where there are none
      rb <- rank_biserial(x, y, paired = TRUE, ci = 0.95)
      interactions[[dv]]$rbc_effectsize <- rb$r_rank_biserial
      interactions[[dv]]$rbc_ci_low_effectsize <- rb$CI_low
      interactions[[dv]]$rbc_ci_high_effectsize <- rb$CI_high
    } else {
      interactions[[dv]][c("rbc_effectsize", "rbc_ci_low_effectsize", "rbc_ci_high_effectsize")] <- NA
    }
  }
  write.csv(do.call(rbind, interactions), file.path(out, "interactions.csv"), row.names = FALSE)

  answers <- read.csv(answers_file, stringsAsFactors = FALSE)
  summary_rows <- list(); test_rows <- list()
  for (item in sort(unique(answers$item))) {
    for (s in sort(unique(answers$interaction))) {
      r <- answers$rating[answers$item == item & answers$interaction == s]
      q <- quantile(r, c(0.25, 0.5, 0.75), type = 7)
      summary_rows[[length(summary_rows) + 1]] <- data.frame(
        item = item, interaction = s, n = length(r), median = median(r), q1 = q[[1]], q3 = q[[3]],
        mean = mean(r), t(sapply(0:10, function(v) sum(r == v))))
    }
    a <- answers[answers$item == item, ]
    x <- a[a$interaction == interaction, c("participant", "rating")]
    y <- a[a$interaction == baseline, c("participant", "rating")]
    pairs <- merge(x, y, by = "participant", suffixes = c("_interaction", "_baseline"))
    sr <- signed_rank(pairs$rating_interaction, pairs$rating_baseline)
    test_rows[[item]] <- data.frame(item = item, n = nrow(pairs), V = sr$V, p_unc = sr$p,
                                    z = sr$z, r = sr$r, rbc = sr$rbc, rbc_ci_low = sr$rbc_ci_low,
                                    rbc_ci_high = sr$rbc_ci_high)
  }
  likert_summary <- do.call(rbind, summary_rows)
  names(likert_summary)[8:18] <- paste0("count_", 0:10)
  write.csv(likert_summary, file.path(out, "likert_summary.csv"), row.names = FALSE)
  tests <- do.call(rbind, test_rows)
  tests$p_bonf <- p.adjust(tests$p_unc, method = "bonferroni")
  write.csv(tests, file.path(out, "likert_tests.csv"), row.names = FALSE)
  for (item in sort(unique(answers$item))) {
    art <- art_reference(answers[answers$item == item, ], "rating", "interaction", "group", "participant", 3)
    for (table in names(art)) write.csv(art[[table]], file.path(out, paste0(table, "_", item, ".csv")), row.names = FALSE)
  }
  trial_model_reference(trials, "group * object * interaction + task_index", "task_index",
                        file.path(out, "trial_model_"))
}

flag <- function(v) v %in% c(TRUE, "True", "true")

power_law_reference <- function(x, y) {
  # y = a + b x^-c, a >= 0, b >= 0, 0 <= c <= 3: nls's port search from the start microg uses, finished
  # by nls's Gauss-Newton on the parameters not at a bound (port stops up to 1e-5 short of the optimum);
  # standard errors by summary.nls's formula at the estimate, sqrt(diag((J'J)^-1) rss / (n - 3))
  law <- deriv(~ a + b * x^(-c), c("a", "b", "c"), function(x, a, b, c) {})
  a0 <- min(y) / 2
  line <- coef(lm(log(y - a0) ~ log(x)))
  start <- list(a = a0, b = exp(line[[1]]), c = min(max(-line[[2]], 0.01), 3 - 0.01))
  port <- tryCatch(nls(y ~ law(x, a, b, c), start = start, algorithm = "port", lower = c(0, 0, 0),
                       upper = c(Inf, Inf, 3), control = list(maxiter = 1000)), error = function(e) NULL)
  if (is.null(port) || !port$convInfo$isConv) return(NULL)
  estimate <- coef(port)
  bound <- c(a = estimate[["a"]] <= 0, b = estimate[["b"]] <= 0, c = estimate[["c"]] >= 3)
  free <- names(bound)[!bound]
  body <- "a + b * x^(-c)"
  for (name in names(bound)[bound]) {
    body <- gsub(paste0("\\b", name, "\\b"), format(estimate[[name]], digits = 17), body, perl = TRUE)
  }
  polish <- deriv(as.formula(paste("~", body)), free, function.arg = c("x", free))
  finish <- NULL
  for (tol in c(1e-10, 1e-9, 1e-8, 1e-7)) {  # the tightest Gauss-Newton reaches (its step halves below minFactor)
    finish <- tryCatch(nls(as.formula(paste0("y ~ polish(x, ", paste(free, collapse = ", "), ")")),
                           start = as.list(estimate[free]), control = nls.control(tol = tol, maxiter = 100)),
                       error = function(e) NULL)
    if (!is.null(finish)) break
  }
  if (!is.null(finish)) estimate[free] <- coef(finish)[free]
  fitted <- law(x, estimate[["a"]], estimate[["b"]], estimate[["c"]])
  rss <- sum((y - fitted)^2)
  jacobian <- attr(fitted, "gradient")
  se <- tryCatch(sqrt(diag(solve(crossprod(jacobian))) * rss / (length(x) - 3)), error = function(e) rep(NA, 3))
  data.frame(a = estimate[["a"]], b = estimate[["b"]], c = estimate[["c"]], a_se = se[1], b_se = se[2],
             c_se = se[3], rss = rss, sigma = sqrt(rss / (length(x) - 3)), polished = !is.null(finish))
}

training_reference <- function(trials_file, out) {
  trials <- read.csv(trials_file, stringsAsFactors = FALSE)
  if ("withdrawn" %in% names(trials)) trials <- trials[!flag(trials$withdrawn), ]
  trials <- trials[order(trials$participant, trials$session_index, trials$task_index), ]
  ran <- !is.na(trials$attempts)
  trials$practice <- ave(as.integer(ran), trials$participant, FUN = cumsum)
  trials$practice[!ran] <- NA
  timed <- trials[flag(trials$completed) & !is.na(trials$time_s) & !is.na(trials$practice), ]
  old <- options(contrasts = c("contr.sum", "contr.poly"))
  on.exit(options(old))
  # the REML surface of a random slope is flat: bobyqa (rhoend 1e-12) stops up to 1e-5 short of the
  # optimum in a correlation, nloptwrap at these tolerances about 1e-7
  control <- lmerControl(optimizer = "nloptwrap", optCtrl = list(xtol_abs = 1e-14, ftol_abs = 1e-16,
                                                                 xtol_rel = 1e-14, ftol_rel = 1e-16, maxeval = 1e5))

  laws <- do.call(rbind, lapply(sort(unique(timed$participant)), function(who) {
    d <- timed[timed$participant == who, ]
    fit <- if (nrow(d) >= 4 && length(unique(d$practice)) >= 3) power_law_reference(d$practice, d$time_s)
    if (is.null(fit)) fit <- data.frame(a = NA, b = NA, c = NA, a_se = NA, b_se = NA, c_se = NA, rss = NA,
                                        sigma = NA, polished = FALSE)
    data.frame(participant = who, group = d$group[1], n = nrow(d), fit, converged = !is.na(fit$a))
  }))
  write.csv(laws, file.path(out, "power_law.csv"), row.names = FALSE)

  timed$log_practice <- log(timed$practice)
  timed$group <- factor(timed$group)
  timed$participant <- factor(timed$participant)
  random <- "(1 + log_practice | participant)"
  fit <- lmer(as.formula(paste("log(time_s) ~ group * log_practice +", random)), data = timed, REML = TRUE,
              control = control)
  with_slope <- !isSingular(fit)
  if (!with_slope) random <- "(1 | participant)"
  if (!with_slope) fit <- lmer(as.formula(paste("log(time_s) ~ group * log_practice +", random)), data = timed,
                               REML = TRUE, control = control)
  write_model(fit, with_slope, nrow(timed), file.path(out, "practice_model_"))
  per_group <- lmer(as.formula(paste("log(time_s) ~ 0 + group + group:log_practice +", random)), data = timed,
                    REML = TRUE, control = control)
  coefficients <- as.data.frame(coef(summary(per_group)))
  terms <- rownames(coefficients)
  write.csv(data.frame(group = sub("^group", "", sub(":log_practice$", "", terms)),
                       parameter = ifelse(grepl(":log_practice$", terms), "slope", "intercept"),
                       estimate = coefficients$Estimate, SE = coefficients$`Std. Error`, df = coefficients$df,
                       t = coefficients$`t value`, p_unc = coefficients$`Pr(>|t|)`),
            file.path(out, "group_curves.csv"), row.names = FALSE)

  has_criterion <- !is.na(trials$criterion_met) & trials$criterion_met != ""
  flagged <- trials[has_criterion, ]
  keys <- unique(flagged[c("participant", "group", "session", "phase")])
  reached <- do.call(rbind, lapply(seq_len(nrow(keys)), function(i) {
    part <- merge(flagged, keys[i, ])
    met <- flag(part$criterion_met)
    tasks <- sum(!is.na(part$attempts))
    data.frame(keys[i, ], tasks = tasks, met = any(met), at = if (any(met)) min(part$task_in_phase[met]) else tasks)
  }))
  km <- list(); medians <- list(); tests <- list()
  for (pair in split(reached, list(reached$session, reached$phase), drop = TRUE)) {
    where <- data.frame(session = pair$session[1], phase = pair$phase[1])
    fit <- survfit(Surv(at, met) ~ group, data = pair)
    s <- summary(fit)
    km[[length(km) + 1]] <- data.frame(where, group = sub("^group=", "", as.character(s$strata)), time = s$time,
                                       n_risk = s$n.risk, n_event = s$n.event, surv = s$surv, se = s$std.err,
                                       ci_low = s$lower, ci_high = s$upper)
    q <- quantile(fit, 0.5)
    medians[[length(medians) + 1]] <- data.frame(where, group = sub("^group=", "", names(fit$strata)), n = fit$n,
                                                 events = as.numeric(tapply(pair$met, pair$group, sum)),
                                                 median = q$quantile[, 1], ci_low = q$lower[, 1],
                                                 ci_high = q$upper[, 1])
    lr <- survdiff(Surv(at, met) ~ group, data = pair)
    df <- length(lr$n) - 1
    tests[[length(tests) + 1]] <- data.frame(where, chi2 = lr$chisq, df = df,
                                             p_unc = pchisq(lr$chisq, df, lower.tail = FALSE), n = sum(lr$n),
                                             events = sum(lr$obs))
  }
  write.csv(do.call(rbind, km), file.path(out, "kaplan_meier.csv"), row.names = FALSE)
  write.csv(do.call(rbind, medians), file.path(out, "medians.csv"), row.names = FALSE)
  write.csv(do.call(rbind, tests), file.path(out, "logrank.csv"), row.names = FALSE)

  sessions <- aggregate(cbind(order = session_index, criterion = has_criterion) ~ session, data = trials,
                        FUN = function(v) if (is.logical(v)) any(v) else min(v))
  sessions <- sessions[order(sessions$order), ]
  test_names <- sessions$session[!sessions$criterion]
  roles <- c(pretest = test_names[1], posttest = test_names[length(test_names) - 1],
             retention = test_names[length(test_names)])
  tested <- trials[trials$session %in% roles & tolower(trials$phase) != "training" & flag(trials$completed) &
                     !is.na(trials$time_s), ]
  cells <- aggregate(time_s ~ participant + group + session, data = tested, FUN = mean)
  res <- mixed_reference(cells, "time_s", "session", "group", "participant", 3)
  for (table in c("anova", "posthoc", "cell_means")) {
    write.csv(res[[table]], file.path(out, paste0("session_", table, ".csv")), row.names = FALSE)
  }
  tested$group <- factor(tested$group)
  tested$session <- factor(tested$session)
  session_fit <- lmer(log(time_s) ~ group * session + (1 | participant), data = tested, REML = TRUE,
                      control = control)
  write_model(session_fit, FALSE, nrow(tested), file.path(out, "session_model_"))

  retention <- do.call(rbind, lapply(sort(unique(cells$group)), function(g) {
    c1 <- cells[cells$group == g, ]
    post <- c1[c1$session == roles[["posttest"]], ]
    later <- c1[c1$session == roles[["retention"]], ]
    ids <- sort(intersect(post$participant, later$participant))
    x <- later$time_s[match(ids, later$participant)]
    y <- post$time_s[match(ids, post$participant)]
    tt <- t.test(x, y, paired = TRUE)
    sr <- signed_rank(x, y)
    dz <- dz_ci(unname(tt$statistic), length(ids))
    data.frame(group = g, measure = "time_s", n = length(ids), mean_posttest = mean(y), sd_posttest = sd(y),
               mean_retention = mean(x), sd_retention = sd(x), mean_diff = mean(x - y),
               diff_ci_low = tt$conf.int[1], diff_ci_high = tt$conf.int[2], T = unname(tt$statistic),
               dof = unname(tt$parameter), p_t = tt$p.value, d_z = mean(x - y) / sd(x - y), d_z_ci_low = dz[1],
               d_z_ci_high = dz[2], cohen_d = mean(x - y) / sqrt((var(x) + var(y)) / 2), V = sr$V,
               p_wilcoxon = sr$p, rbc = sr$rbc, rbc_ci_low = sr$rbc_ci_low, rbc_ci_high = sr$rbc_ci_high,
               n_nonzero = sr$n_nonzero, p_shapiro = shapiro.test(x - y)$p.value)
  }))
  write.csv(retention, file.path(out, "retention.csv"), row.names = FALSE)
}

args <- commandArgs(trailingOnly = TRUE)
if (length(args) == 8 && args[1] == "mixed") {
  data <- read.csv(args[2], stringsAsFactors = FALSE)
  res <- c(mixed_reference(data, args[3], args[4], args[5], args[6], as.integer(args[7])),
           art_reference(data, args[3], args[4], args[5], args[6], as.integer(args[7])))
  for (table in names(res)) write.csv(res[[table]], paste0(args[8], "_", table, ".csv"), row.names = FALSE)
} else if (length(args) == 6 && args[1] == "study") {
  study_reference(args[2], args[3], args[4], args[5], args[6])
} else if (length(args) == 3 && args[1] == "training") {
  training_reference(args[2], args[3])
} else if (length(args) == 5 && args[1] == "trials") {
  trial_model_reference(read.csv(args[2], stringsAsFactors = FALSE), args[3], args[4], args[5])
} else {
  stop("usage: reference.R mixed DATA DV WITHIN BETWEEN SUBJECT SS_TYPE OUT_PREFIX | ",
       "reference.R study TRIALS QUESTIONNAIRE INTERACTION BASELINE OUT_DIR | ",
       "reference.R trials TRIALS FIXED SLOPE OUT_PREFIX | reference.R training TRIALS OUT_DIR")
}
