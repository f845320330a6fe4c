#!/usr/bin/env bash
# Installs the Debian 12 packages dgv needs, only those that are missing (a second run does
# nothing). Usage: scripts/install-deps.sh [--tests] [--fuzz] [--farm]
#   --tests  also what the test suite needs (assimp's test models, OpenVDB's and OpenEXR's tools,
#            Blender and the NumPy its glTF importer needs, for the mesh cache's import test)
#   --fuzz   also clang and its runtime with libFuzzer (scripts/fuzz.sh)
#   --farm   also Slurm and munge, for the one-node cluster of scripts/farm-test.sh
set -euo pipefail

build_pkgs=(build-essential cmake ninja-build pkg-config
  libeigen3-dev libtbb-dev libassimp-dev libosmesa6-dev libegl-dev libegl-mesa0 libgl1-mesa-dri libpng-dev
  libopenexr-dev libstb-dev libopenvdb-dev libboost-iostreams-dev nlohmann-json3-dev libcli11-dev catch2)
test_pkgs=(assimp-testmodels libopenvdb-tools openexr blender python3-numpy)
fuzz_pkgs=(clang libclang-rt-14-dev)
farm_pkgs=(slurm-wlm munge)

pkgs=("${build_pkgs[@]}")
for arg in "$@"; do
  case "$arg" in
    --tests) pkgs+=("${test_pkgs[@]}") ;;
    --fuzz) pkgs+=("${fuzz_pkgs[@]}") ;;
    --farm) pkgs+=("${farm_pkgs[@]}") ;;
    *) echo "install-deps: unknown option '$arg' (expected --tests, --fuzz or --farm)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${pkgs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#pkgs[@]} packages present"
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null; then sudo="sudo"; else
    echo "install-deps: missing packages (${missing[*]}) and not root; install them as root" >&2
    exit 1
  fi
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
# Packages with daemons (munge, slurm) must not start them on install: farm-test.sh starts its own
# and requires none left behind. Debian's policy-rc.d hook, exit 101, forbids any service start;
# one is put in place for the install only when the machine has none of its own.
policy=/usr/sbin/policy-rc.d
if [[ ! -e $policy ]]; then
  printf '#!/bin/sh\nexit 101\n' | $sudo tee "$policy" >/dev/null
  $sudo chmod 755 "$policy"
  trap '$sudo rm -f "$policy"' EXIT
fi
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
