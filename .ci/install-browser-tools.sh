#!/usr/bin/env bash
# Installs what tests/web_page.rs needs to drive the web page in a real
# browser, on a Debian/Ubuntu CI machine, as root, with no standard input:
# Debian's Chromium (/usr/bin/chromium), Node.js with npm, and the pinned
# playwright-core from tests/browser/package-lock.json (`npm ci`; it never
# downloads a browser of its own). Idempotent: a re-run finds everything in
# place and returns in about a second.
#
# It fails (exit 1, with the reason on stderr) when something cannot be
# installed, so that CI stops there rather than skipping the browser test.
# On success it prints one line.
set -uo pipefail
export DEBIAN_FRONTEND=noninteractive
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
NAME=install-browser-tools
log=/tmp/isoremesh-install-browser-tools.log
# shellcheck source=lib.sh
. "$(dirname "$0")/lib.sh"
cd "$(dirname "$0")/.."


installed=""
need=()
[ -x /usr/bin/chromium ] || need+=(chromium)
command -v node >/dev/null 2>&1 || need+=(nodejs)
command -v npm >/dev/null 2>&1 || need+=(npm)
if [ "${#need[@]}" -gt 0 ]; then
    [ "$(id -u)" = 0 ] || fail "not root: cannot install ${need[*]}"
    command -v apt-get >/dev/null 2>&1 || fail "no apt-get; cannot install ${need[*]}"
    if ! retry apt-get update -q >>"$log" 2>&1; then
        say "apt-get update failed; trying the install anyway"
    fi
    if ! retry apt-get install -y -q --no-install-recommends "${need[@]}" fonts-dejavu-core >>"$log" 2>&1; then
        fail "could not install ${need[*]} (log: $log)"
    fi
    installed="installed ${need[*]}; "
fi
major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)
[ "$major" -ge 20 ] || fail "Node.js $(node --version 2>/dev/null) is older than 20, which playwright-core needs"
/usr/bin/chromium --version >/dev/null 2>&1 || fail "/usr/bin/chromium does not run"

# npm ci only when the lock file changed since the last install.
stamp=tests/browser/node_modules/.isoremesh-lock.sha256
want=$(sha256sum tests/browser/package-lock.json | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ] ||
    [ ! -f tests/browser/node_modules/playwright-core/package.json ]; then
    if ! (cd tests/browser && retry npm ci --no-audit --no-fund >>"$log" 2>&1); then
        fail "npm ci in tests/browser failed (log: $log)"
    fi
    echo "$want" >"$stamp"
    installed="${installed}npm ci in tests/browser; "
fi
echo "install-browser-tools: ${installed}$(/usr/bin/chromium --version 2>/dev/null | head -1), node $(node --version), playwright-core $(node -p 'require("./tests/browser/node_modules/playwright-core/package.json").version')"
