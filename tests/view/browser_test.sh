#!/usr/bin/env bash
# The page of `dofcache view` in headless Chromium (tests/view/browser/browser_test.js).
# Usage: browser_test.sh DOFCACHE_EXE SOURCE_DIR OUT_DIR
# Exit 77 (reported by ctest as skipped, never passed) where the browser, Node.js or the test's
# npm packages are absent: `bash .ci/install-deps --browser-tests` installs them.
set -uo pipefail
exe="$1"; src="$2"; out="$3"
dir="$src/tests/view/browser"
chromium="${CHROMIUM:-/usr/bin/chromium}"
if [ ! -x "$chromium" ]; then
  echo "SKIPPED: no Chromium at $chromium (bash .ci/install-deps --browser-tests)"; exit 77
fi
if ! command -v node >/dev/null; then
  echo "SKIPPED: Node.js is not installed (bash .ci/install-deps --browser-tests)"; exit 77
fi
if [ ! -d "$dir/node_modules/puppeteer-core" ]; then
  echo "SKIPPED: puppeteer-core is not installed in $dir (bash .ci/install-deps --browser-tests)"
  exit 77
fi
CHROMIUM="$chromium" exec node "$dir/browser_test.js" "$exe" "$src/scenes/color_spheres.gltf" "$out"
