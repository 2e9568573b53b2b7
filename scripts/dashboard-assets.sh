#!/usr/bin/env bash
# Put the console's third-party browser files (uPlot, from npm) next to the page.
# They are not committed: the project holds only code we wrote. Needs Node/npm; run from anywhere.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
vendor="$root/python/src/nurimc/dashboard/static/vendor/uplot"
if [ ! -d "$root/e2e/node_modules/uplot" ]; then
  (cd "$root/e2e" && npm ci --silent --no-audit --no-fund >/dev/null)
fi
src="$root/e2e/node_modules/uplot"
mkdir -p "$vendor"
cp "$src/dist/uPlot.esm.js" "$src/dist/uPlot.min.css" "$src/LICENSE" "$vendor/"
node -p "require('$src/package.json').version" > "$vendor/VERSION"
