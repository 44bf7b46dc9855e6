#!/usr/bin/env bash
# Regenerate the R reference values the analysis tests hold (run from anywhere; needs Rscript with
# afex and emmeans, e.g. Debian's r-base-core r-cran-afex r-cran-emmeans, and the project's venv).
#   - afex/emmeans on the mixed_anova datasets that pingouin ships: printed; the values are written
#     into tests/analysis/test_anova.py and tests/analysis/test_posthoc.py
#   - expected/study/: the whole analysis of study_trials.csv + study_questionnaire.csv
#     (made once with tests/analysis/study_data.py: make_study(seed=11))
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
python="${PYTHON:-$here/../../../.venv/bin/python}"
datasets="$("$python" -c 'import os, pingouin; print(os.path.join(os.path.dirname(pingouin.__file__), "datasets"))')"
printed="$(mktemp -d)"
for dataset in mixed_anova mixed_anova_unbalanced; do
  for type in 2 3; do
    Rscript "$here/reference.R" mixed "$datasets/$dataset.csv" Scores Time Group Subject $type "$printed/${dataset}_type$type"
    echo "== $dataset, type $type"
    cat "$printed/${dataset}_type${type}_anova.csv" "$printed/${dataset}_type${type}_posthoc.csv"
  done
done
rm -r "$printed"
mkdir -p "$here/expected/study"
Rscript "$here/reference.R" study "$here/study_trials.csv" "$here/study_questionnaire.csv" \
  impulse_penetration soft_hand "$here/expected/study"
