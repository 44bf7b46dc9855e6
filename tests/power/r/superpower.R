# Reference values for microg.power, computed with R's Superpower 0.2.4.1, afex, emmeans and MASS.
#
#   Rscript superpower.R EFFECTS.csv COVARIANCE.csv OUT_DIR SIMS
#     EFFECTS.csv: group, level, mean (the design's order); COVARIANCE.csv: group, a, b, value
#     (reproduce.sh writes both from nonspherical.toml). A 2 x 3 mixed design, alpha .05, target .8:
#     exact.csv: Superpower's ANOVA_exact (correction none, GG, HF) at n = 8 and 15 per group:
#       power, partial eta squared, Cohen's f, noncentrality of each term; and each post hoc contrast
#       family (emmeans on afex's multivariate model) through emmeans_power at alpha / family size;
#     exact_unequal.csv: the same by hand for groups of 12 and 9 (Superpower's ANOVA_exact takes equal
#       groups only): MASS::mvrnorm(empirical = TRUE) per group, afex::aov_ez type 3 (with afex's GG/HF
#       correction of df), lambda = F x df1, power from pf; contrasts from emmeans, power from pt;
#     sensitivity.csv: the smallest Cohen's f reaching power .8 by uniroot (tolerance 1e-14) on
#       Superpower's power.ftest (lambda = f^2 df2), for every test at n = 15, 15 with GG, and 12 + 9;
#       R's own scale of the pattern (sqrt(lambda needed / lambda of the pattern)), checked by running
#       ANOVA_exact on the means scaled by it (power_scaled, equal groups);
#     effect_sizes.csv: power.ftest for f = .1, .25, .4 for every test at n = 10 and 20;
#     montecarlo.csv: ANOVA_power (correction GG and HF, SIMS data sets, seed 2024) at n = 8 (SIMS = 0: not run).
suppressMessages({
  library(Superpower)
  library(afex)
  library(emmeans)
  library(MASS)
})

args <- commandArgs(trailingOnly = TRUE)
if (length(args) != 4) stop("usage: superpower.R EFFECTS.csv COVARIANCE.csv OUT_DIR SIMS")
effects <- read.csv(args[1], stringsAsFactors = FALSE)
covariance <- read.csv(args[2], stringsAsFactors = FALSE)
out <- args[3]
sims <- as.integer(args[4])
alpha <- 0.05
target <- 0.8

groups <- unique(effects$group)
levels <- unique(effects$level)
g <- length(groups)
k <- length(levels)
sigma <- lapply(groups, function(group) {
  rows <- covariance[covariance$group == group, ]
  matrix(rows$value, k, k, byrow = TRUE, dimnames = list(levels, levels))
})
cell_means <- lapply(groups, function(group) effects$mean[effects$group == group])
families <- list(object = "object", `group | object` = "group | object", `object | group` = "object | group")
plain <- gsub("_", "", levels)  # Superpower's labels may not hold an underscore

restore <- function(names) {
  # Superpower's contrast names ("group_beginner - group_veteran | object_flatcuboid") as microg names
  # them: levels as given, each pair in the design's order (power does not depend on the sign)
  names <- gsub("(group|object)_", "", names)
  for (i in seq_along(levels)) names <- gsub(paste0("\\b", plain[i], "\\b"), levels[i], names)
  vapply(strsplit(names, " | ", fixed = TRUE), function(parts) {
    pair <- strsplit(parts[1], " - ", fixed = TRUE)[[1]]
    order <- match(pair, if (all(pair %in% groups)) groups else levels)
    if (order[1] > order[2]) pair <- rev(pair)
    paste(c(paste(pair, collapse = " - "), parts[-1]), collapse = " | ")
  }, character(1))
}

superpower_design <- function(n, scale = 1) {
  mu <- unlist(cell_means)
  mu <- mean(mu) + scale * (mu - mean(mu))
  r <- matrix(0, g * k, g * k)
  for (i in seq_len(g)) {
    correlation <- cov2cor(sigma[[i]])
    r[(i - 1) * k + 1:k, (i - 1) * k + 1:k] <- (correlation + t(correlation)) / 2  # cov2cor's last bit is not
  }
  ANOVA_design(design = paste0(g, "b*", k, "w"), n = n, mu = mu, sd = sqrt(unlist(lapply(sigma, diag))), r = r,
               label_list = list(group = groups, object = plain), plot = FALSE)
}

contrast_name <- function(table, family) {
  if (family == "object") return(as.character(table$contrast))
  at <- if (family == "group | object") table$object else table$group
  paste(table$contrast, "|", at)
}

t_power <- function(t, df, alpha) {
  critical <- qt(alpha / 2, df, lower.tail = FALSE)
  pt(critical, df, ncp = t, lower.tail = FALSE) + pt(-critical, df, ncp = t)
}

# Superpower's ANOVA_exact, equal groups
exact <- do.call(rbind, lapply(c(8, 15), function(n) {
  design <- superpower_design(n)
  terms <- do.call(rbind, lapply(c("none", "GG", "HF"), function(correction) {
    x <- ANOVA_exact(design, correction = correction, alpha_level = alpha, verbose = FALSE)
    main <- x$main_results
    data.frame(n_per_group = n, correction = correction, term = rownames(main), power = main$power / 100,
               np2 = main$partial_eta_squared, cohen_f = main$cohen_f, noncentrality = main$non_centrality)
  }))
  contrasts <- do.call(rbind, lapply(names(families), function(family) {
    x <- ANOVA_exact(design, alpha_level = alpha, verbose = FALSE, emm = TRUE, emm_comp = families[[family]])
    table <- as.data.frame(x$emmeans$contrasts)
    powered <- emmeans_power(x$emmeans$contrasts, alpha_level = alpha / nrow(table))
    data.frame(n_per_group = n, correction = "none", term = restore(contrast_name(table, family)),
               power = powered$power / 100, np2 = powered$partial_eta_squared, cohen_f = powered$cohen_f,
               noncentrality = powered$non_centrality)
  }))
  rbind(terms, contrasts)
}))
write.csv(exact, file.path(out, "exact.csv"), row.names = FALSE)

# the ANOVA_exact way by hand, for groups of any size
exact_data <- function(sizes, scale = 1) {
  grand <- mean(unlist(cell_means))
  do.call(rbind, lapply(seq_len(g), function(i) {
    values <- mvrnorm(sizes[i], grand + scale * (cell_means[[i]] - grand), sigma[[i]], empirical = TRUE)
    data.frame(participant = rep(paste0(groups[i], seq_len(sizes[i])), k), group = groups[i],
               object = rep(levels, each = sizes[i]), value = as.vector(values))
  }))
}
by_hand <- function(sizes, label) {
  # every test: uncorrected df, family size, epsilon applied, uncorrected lambda (t^2 for a contrast), power
  d <- exact_data(sizes)
  d$group <- factor(d$group, levels = groups)
  d$object <- factor(d$object, levels = levels)
  error <- sum(sizes) - g
  plain_df1 <- c(g - 1, k - 1, (g - 1) * (k - 1))
  plain_df2 <- c(error, (k - 1) * error, (k - 1) * error)
  terms <- do.call(rbind, lapply(c("none", "GG", "HF"), function(correction) {
    fit <- suppressMessages(aov_ez(id = "participant", dv = "value", data = d, between = "group", within = "object",
                                   type = 3, anova_table = list(correction = correction, es = "pes")))
    table <- as.data.frame(fit$anova_table)
    df1 <- table$`num Df`
    df2 <- table$`den Df`
    data.frame(n_per_group = label, correction = correction, term = rownames(table), df1 = plain_df1,
               df2 = plain_df2, family = 1, epsilon = df1 / plain_df1, lambda = table$F * plain_df1,
               power = pf(qf(alpha, df1, df2, lower.tail = FALSE), df1, df2, ncp = table$F * df1, lower.tail = FALSE),
               np2 = table$pes)
  }))
  fit <- suppressMessages(aov_ez(id = "participant", dv = "value", data = d, between = "group", within = "object",
                                 type = 3))
  specs <- list(object = ~ object, `group | object` = ~ group | object, `object | group` = ~ object | group)
  contrasts <- do.call(rbind, lapply(names(specs), function(family) {
    table <- as.data.frame(summary(pairs(emmeans(fit, specs[[family]])), by = NULL, adjust = "none"))
    data.frame(n_per_group = label, correction = "none", term = contrast_name(table, family), df1 = 1,
               df2 = table$df, family = nrow(table), epsilon = 1, lambda = table$t.ratio^2,
               power = t_power(table$t.ratio, table$df, alpha / nrow(table)),
               np2 = table$t.ratio^2 / (table$t.ratio^2 + table$df))
  }))
  rbind(terms, contrasts)
}
unequal <- rbind(by_hand(c(12, 9), "veteran=12,beginner=9"), by_hand(c(8, 8), "8"))
write.csv(unequal, file.path(out, "exact_unequal.csv"), row.names = FALSE)

# sensitivity: the smallest f by power.ftest, and the scale of the pattern that reaches it
smallest_f <- function(df1, df2, alpha) {
  uniroot(function(f) power.ftest(num_df = df1, den_df = df2, cohen_f = f, alpha_level = alpha)$power / 100 - target,
          c(1e-6, 100), tol = 1e-14)$root
}
cases <- list(list(c(15, 15), "15", "none"), list(c(15, 15), "15", "GG"),
              list(c(12, 9), "veteran=12,beginner=9", "none"))
sensitivity <- do.call(rbind, lapply(cases, function(case) {
  rows <- by_hand(case[[1]], case[[2]])
  rows <- rows[rows$correction == case[[3]] | rows$family > 1, ]
  f <- mapply(function(df1, df2, e, m) smallest_f(df1 * e, df2 * e, alpha / m), rows$df1, rows$df2, rows$epsilon,
              rows$family)
  data.frame(n_per_group = case[[2]], correction = case[[3]], term = rows$term, cohen_f = f, np2 = f^2 / (1 + f^2),
             noncentrality = f^2 * rows$df2, scale = sqrt(f^2 * rows$df2 / rows$lambda), epsilon = rows$epsilon,
             power = mapply(function(df1, df2, e, m, x) power.ftest(df1 * e, df2 * e, x, alpha / m)$power / 100,
                            rows$df1, rows$df2, rows$epsilon, rows$family, f))
}))
# Superpower itself at the scaled means: the term then has the target power (equal groups)
sensitivity$power_scaled <- NA
for (i in which(sensitivity$n_per_group == "15" & sensitivity$term %in% c("group", "object", "group:object"))) {
  x <- ANOVA_exact(superpower_design(15, sensitivity$scale[i]), correction = sensitivity$correction[i],
                   alpha_level = alpha, verbose = FALSE)
  sensitivity$power_scaled[i] <- x$main_results[sensitivity$term[i], "power"] / 100
}
write.csv(sensitivity, file.path(out, "sensitivity.csv"), row.names = FALSE)

# power from an effect size: power.ftest at lambda = f^2 df2
effect_sizes <- do.call(rbind, lapply(c(10, 20), function(n) {
  error <- g * (n - 1)
  tests <- data.frame(term = c("group", "object", "group:object", "cube - flat_cuboid",
                               "veteran - beginner | cube", "cube - flat_cuboid | veteran"),
                      df1 = c(g - 1, k - 1, (g - 1) * (k - 1), 1, 1, 1),
                      df2 = c(error, (k - 1) * error, (k - 1) * error, error, error, error),
                      family = c(1, 1, 1, 3, 3, 6))
  do.call(rbind, lapply(c(0.1, 0.25, 0.4), function(f) {
    data.frame(n_per_group = n, term = tests$term, cohen_f = f,
               power = mapply(function(a, b, m) power.ftest(a, b, f, alpha / m)$power / 100,
                              tests$df1, tests$df2, tests$family))
  }))
}))
write.csv(effect_sizes, file.path(out, "effect_sizes.csv"), row.names = FALSE)

# Superpower's Monte Carlo with a correction always applied (SIMS = 0: not run)
if (sims > 0) {
  montecarlo <- do.call(rbind, lapply(c("GG", "HF"), function(correction) {
    x <- ANOVA_power(superpower_design(8), alpha_level = alpha, correction = correction, nsims = sims, seed = 2024,
                     verbose = FALSE)
    data.frame(n_per_group = 8, correction = correction, term = sub("^anova_", "", rownames(x$main_results)),
               power = x$main_results$power / 100, sims = sims)
  }))
  write.csv(montecarlo, file.path(out, "montecarlo.csv"), row.names = FALSE)
}
