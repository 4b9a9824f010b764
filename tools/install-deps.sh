#!/usr/bin/env bash
# Installs the Debian packages lec6 needs, only those that are missing.
# `apt-get update` runs once, and only when something has to be installed.
set -euo pipefail

packages=(
  build-essential cmake pkg-config clang libclang-rt-14-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libfmt-dev nlohmann-json3-dev libasio-dev
  libmodbus-dev mbpoll python3 python3-pymodbus python3-serial
  # the Python module (python/): build, pytest suite, offline `pip install` in a venv
  pybind11-dev python3-dev python3-pytest python3-venv
  python3-setuptools-whl python3-wheel-whl python3-pip-whl
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  exit 0
fi

echo "Installing missing Debian packages: ${missing[*]}"
sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
