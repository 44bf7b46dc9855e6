#!/usr/bin/env bash
# Regenerate the R reference values the analysis tests hold (run from anywhere; needs Rscript with
# afex, emmeans, car, rstatix, effectsize, geepack, lme4 and lmerTest, e.g. Debian's r-base-core
# r-cran-afex r-cran-emmeans r-cran-car r-cran-rstatix r-cran-effectsize r-cran-geepack r-cran-lmertest,
# ARTool 0.11.2 (R CMD INSTALL of ../shared/reference/r/ARTool_0.11.2.tar.gz), and the project's venv).
#   - expected/mixed/: afex/emmeans/car/rstatix and ARTool on the mixed_anova datasets that pingouin
#     ships (types 2 and 3) and on zero_effect.csv (both groups hold the same values: group and
#     interaction sums of squares are exactly 0)
#   - expected/study/: the whole analysis of study_trials.csv + study_questionnaire.csv
#     (made once with tests/analysis/study_data.py: make_study(seed=11)), ART and the trial model included
#   - expected/practice/: lme4/lmerTest on practice_trials.csv (make_practice(seed=3)), whose
#     participants practise at rates of their own: a random slope that is not singular
#   - expected/training/: a training program's section (nls, lme4/lmerTest, survival, afex/emmeans) on
#     training_trials.csv, made once with tests/analysis/training_data.py: make_training(seed=2026)
#     (PYTHONPATH=../../.. python -c "from tests.analysis.training_data import make_training;
#     make_training(2026).to_csv('training_trials.csv', index=False)"); needs R's survival too
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
python="${PYTHON:-$here/../../../.venv/bin/python}"
datasets="$("$python" -c 'import os, pingouin; print(os.path.join(os.path.dirname(pingouin.__file__), "datasets"))')"
mkdir -p "$here/expected/mixed" "$here/expected/study" "$here/expected/practice" "$here/expected/training"
for dataset in mixed_anova mixed_anova_unbalanced; do
  for type in 2 3; do
    Rscript "$here/reference.R" mixed "$datasets/$dataset.csv" Scores Time Group Subject $type \
      "$here/expected/mixed/${dataset}_type$type"
  done
done
Rscript "$here/reference.R" mixed "$here/zero_effect.csv" attempts object group participant 3 \
  "$here/expected/mixed/zero_effect_type3"
Rscript "$here/reference.R" study "$here/study_trials.csv" "$here/study_questionnaire.csv" \
  impulse_penetration soft_hand "$here/expected/study"
Rscript "$here/reference.R" trials "$here/practice_trials.csv" "group * object + task_index" task_index \
  "$here/expected/practice/trial_model_"
Rscript "$here/reference.R" training "$here/training_trials.csv" "$here/expected/training"
