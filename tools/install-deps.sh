#!/usr/bin/env bash
# install-deps.sh - installs the Debian 12 packages the build needs, and only
# those that are missing.  Needs root (or sudo) when something is missing.
set -euo pipefail
pkgs=(build-essential libosmesa6-dev libopenexr-dev libtinygltf-dev nlohmann-json3-dev
      libpng-dev clang libclang-rt-14-dev)
missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "install-deps: installing ${missing[*]}"
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
