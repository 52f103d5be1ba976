#!/usr/bin/env bash
# install-deps.sh - the Debian 12 packages the build needs.
#   tools/install-deps.sh          installs those that are missing (root or sudo)
#   tools/install-deps.sh --check  only names the missing ones; exit 1 if any
# (and the browser test's npm packages: npm ci in test/browser)
# `make deps` and `make demo` install; `make test`, `make bench` and
# `make report` only check, so they never run apt-get.
set -euo pipefail
# openmpi: `mpirun` spreads rows over ranks (docs/cluster.md); libegl + the
# Mesa drivers: the EGL back end (loaded at run time, like OSMesa);
# pkg-config: the installed library's test; chromium + nodejs: the baked
# glTF's browser test (test/browser).
pkgs=(build-essential libosmesa6-dev libopenexr-dev libtinygltf-dev nlohmann-json3-dev
      libpng-dev libstb-dev libembree-dev clang libclang-rt-14-dev
      openmpi-bin libopenmpi-dev libegl-dev libegl-mesa0 libgl1-mesa-dri
      pkg-config chromium)
missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
# Node.js may come from Debian (nodejs + npm) or from NodeSource (one
# package holding both, which conflicts with Debian's npm): ask for the
# commands, not the packages.
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)
# The browser test's npm packages (test/browser/package-lock.json: the
# glTF validator, three.js, puppeteer-core) live in test/browser/node_modules,
# installed by `npm ci`; current when every package the lock file names is
# there at its locked version.
browser="$(cd "$(dirname "$0")/.." && pwd)/test/browser"
npm_current() {
    [ -d "$browser/node_modules" ] && command -v node >/dev/null 2>&1 && node -e '
        const fs = require("fs"), dir = process.argv[1];
        const lock = JSON.parse(fs.readFileSync(dir + "/package-lock.json", "utf8"));
        for (const [at, p] of Object.entries(lock.packages || {})) {
            if (!at || p.optional) continue;
            const f = dir + "/" + at + "/package.json";
            if (!fs.existsSync(f) || JSON.parse(fs.readFileSync(f, "utf8")).version !== p.version)
                process.exit(1);
        }' "$browser"
}
if [ "${1:-}" = "--check" ]; then
    rc=0
    if [ ${#missing[@]} -ne 0 ]; then
        echo "missing Debian packages: ${missing[*]}; run 'make deps' (it installs them)" >&2
        rc=1
    fi
    if ! npm_current; then
        echo "test/browser/node_modules is missing or not what package-lock.json pins; run 'make deps' (npm ci there)" >&2
        rc=1
    fi
    exit $rc
fi
if [ ${#missing[@]} -ne 0 ]; then
    echo "install-deps: installing ${missing[*]}"
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
if ! npm_current; then
    echo "install-deps: npm ci in test/browser"
    (cd "$browser" && npm ci --no-audit --no-fund)
fi
