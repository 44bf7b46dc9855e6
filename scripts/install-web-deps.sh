#!/usr/bin/env bash
# Front-end packages of the participant view, from the npm registry at the exact versions of
# package-lock.json (npm ci), copied into the Python package (microg/view/page/vendor/) so the page
# works with no internet and a built wheel ships them with their licence. Never committed.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v npm >/dev/null; then
  echo "error: npm (Node.js) is needed to install the participant view's three.js; install nodejs and npm" >&2
  exit 1
fi
npm ci --no-audit --no-fund --loglevel=error
vendor=microg/view/page/vendor
mkdir -p "$vendor"
cp node_modules/three/build/three.module.js node_modules/three/build/three.core.js "$vendor/"
cp node_modules/three/LICENSE "$vendor/three.LICENSE"
echo "three $(node -p "require('./node_modules/three/package.json').version") -> $vendor"
