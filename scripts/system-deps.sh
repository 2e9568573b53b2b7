#!/usr/bin/env bash
# Install the Debian packages the tests need, once. Needs root (CI runs as root).
set -euo pipefail
want=(python3-venv clang gcc-arm-none-eabi libnewlib-arm-none-eabi chromium valgrind ninja-build cmake
  gcc-avr avr-libc arduino-core-avr arduino-mk arduino-builder simavr libsimavr-dev qemu-system-arm sigrok-cli)
missing=()
for pkg in "${want[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" != 0 ]; then
  echo "missing Debian packages: ${missing[*]}; run as root: apt-get install ${missing[*]}" >&2
  exit 1
fi
echo "installing: ${missing[*]}"
apt-get update -qq
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
