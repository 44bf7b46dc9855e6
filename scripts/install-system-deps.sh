#!/usr/bin/env bash
# System packages some tests use: Chromium and its driver (the 3D view's browser test) and R with afex,
# emmeans, car, rstatix, effectsize, geepack, lmerTest and survival (the live cross-check of the statistics), then the
# R packages Debian lacks, ARTool and Superpower, built from the source tarballs in ../shared/reference/r/
# when ../shared is there (their dependencies are the Debian packages below). Installed when this machine
# allows; otherwise the tests that need them skip and say why.
set -u
packages=(chromium chromium-driver r-base-core r-cran-afex r-cran-emmeans r-cran-car r-cran-rstatix r-cran-effectsize
          r-cran-geepack r-cran-lme4 r-cran-lmertest r-cran-plyr r-cran-magrittr r-cran-dplyr r-cran-ggplot2
          r-cran-reshape2 r-cran-tidyselect r-cran-tidyr r-cran-mass r-cran-survival)
tarballs=(ARTool_0.11.2 Superpower_0.2.4.1)
shared="$(cd "$(dirname "$0")/.." && pwd)/../shared/reference/r"

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then sudo="sudo -n"; else sudo="none"; fi
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if ! command -v apt-get >/dev/null; then
    echo "note: no apt-get here; tests needing ${missing[*]} will skip" >&2
  elif [ "$sudo" = "none" ]; then
    echo "note: not root and no sudo; tests needing ${missing[*]} will skip" >&2
  else
    echo "installing system packages: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get update -qq >/dev/null && $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null \
      || echo "note: apt-get could not install ${missing[*]}; tests needing them will skip" >&2
  fi
fi

command -v Rscript >/dev/null || exit 0
for tarball in "${tarballs[@]}"; do
  name="${tarball%%_*}"
  Rscript -e "quit(status = !requireNamespace('$name', quietly = TRUE))" >/dev/null 2>&1 && continue
  if [ ! -f "$shared/$tarball.tar.gz" ]; then
    echo "note: no $shared/$tarball.tar.gz; tests needing R's $name will skip" >&2
  elif [ "$sudo" = "none" ]; then
    echo "note: not root and no sudo; tests needing R's $name will skip" >&2
  else
    echo "installing R package $name from $shared/$tarball.tar.gz"
    $sudo R CMD INSTALL "$shared/$tarball.tar.gz" >/dev/null 2>&1 \
      || echo "note: R CMD INSTALL $tarball.tar.gz failed; tests needing R's $name will skip" >&2
  fi
done
exit 0
