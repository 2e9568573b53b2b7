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
install() { DEBIAN_FRONTEND=noninteractive apt-get install -y -qq -o DPkg::Lock::Timeout=600 "$@" >/dev/null; }
if ! install "${missing[@]}"; then
  # Some machines delete downloaded archives after every dpkg run, so an install that needs several
  # runs can find its archives gone: retry once with a fresh download, then name what failed.
  echo "apt-get install failed; retrying once with a fresh download" >&2
  apt-get clean
  apt-get update -qq
  if ! install "${missing[@]}"; then
    failed=()
    for pkg in "${missing[@]}"; do install "$pkg" || failed+=("$pkg"); done
    if [ ${#failed[@]} -gt 0 ]; then
      echo "could not install Debian package(s): ${failed[*]} (see apt-get's messages above); try: apt-get install ${failed[*]}" >&2
      exit 1
    fi
  fi
fi
