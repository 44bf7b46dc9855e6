#!/usr/bin/env bash
# Regenerate the Superpower reference values the power tests hold (run from anywhere; needs Rscript with
# Superpower 0.2.4.1 (R CMD INSTALL ../shared/reference/r/Superpower_0.2.4.1.tar.gz after Debian's
# r-cran-afex r-cran-emmeans r-cran-mass r-cran-ggplot2 r-cran-reshape2 r-cran-dplyr r-cran-magrittr
# r-cran-tidyselect r-cran-tidyr) and the project's venv). The effects are nonspherical.toml, exported
# for R by microg.power's own reader; expected/montecarlo.csv takes a few minutes (2 x SIMS data sets).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
python="${PYTHON:-$here/../../../.venv/bin/python}"
sims="${SIMS:-2000}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$python" - "$here/nonspherical.toml" "$work" <<'PY'
import sys
from tests.power.superpower_data import export_effects
export_effects(sys.argv[1], sys.argv[2])
PY
mkdir -p "$here/expected"
Rscript "$here/superpower.R" "$work/effects.csv" "$work/covariance.csv" "$here/expected" "$sims"
