#!/usr/bin/env bash
# System packages some tests use: Chromium and its driver (the 3D view's browser test) and R with afex,
# emmeans, car, rstatix, effectsize and geepack (the live cross-check of the statistics). Installed with
# apt when this machine allows; otherwise the tests that need them skip and say why.
set -u
packages=(chromium chromium-driver r-base-core r-cran-afex r-cran-emmeans r-cran-car r-cran-rstatix r-cran-effectsize
          r-cran-geepack)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if ! command -v apt-get >/dev/null; then
  echo "note: no apt-get here; tests needing ${missing[*]} will skip" >&2; exit 0
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then sudo="sudo -n"; else
    echo "note: not root and no sudo; tests needing ${missing[*]} will skip" >&2; exit 0
  fi
fi
echo "installing system packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq >/dev/null && $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null \
  || echo "note: apt-get could not install ${missing[*]}; tests needing them will skip" >&2
exit 0
