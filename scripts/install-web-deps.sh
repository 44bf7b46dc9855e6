#!/usr/bin/env bash
# Front-end packages of the participant view (three.js) and the dashboard (Chart.js), from the npm
# registry at the exact versions of package-lock.json (npm ci), copied into the Python package
# (microg/view/page/vendor/) so the pages work with no internet and a built wheel ships them with
# their licences. Never committed.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v npm >/dev/null; then
  echo "error: npm (Node.js) is needed to install the participant view's three.js and the dashboard's Chart.js; install nodejs and npm" >&2
  exit 1
fi
npm ci --no-audit --no-fund --loglevel=error
vendor=microg/view/page/vendor
mkdir -p "$vendor"
cp node_modules/three/build/three.module.js node_modules/three/build/three.core.js "$vendor/"
cp node_modules/three/LICENSE "$vendor/three.LICENSE"
cp node_modules/chart.js/dist/chart.umd.min.js "$vendor/chart.umd.min.js"
cp node_modules/chart.js/LICENSE.md "$vendor/chart.LICENSE.md"
for package in three chart.js; do
  echo "$package $(node -p "require('./node_modules/$package/package.json').version") -> $vendor"
done
