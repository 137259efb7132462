#!/usr/bin/env bash
# open3d needs libusb-1.0 at import time. Install it with apt when running as root,
# otherwise print the one command that installs it.
set -euo pipefail
# read the whole list first: `ldconfig -p | grep -q` under pipefail fails whenever
# grep exits at the first match and ldconfig gets SIGPIPE (a false "missing")
libs=$(ldconfig -p 2>/dev/null || true)
if [[ "$libs" == *libusb-1.0.so.0* ]]; then
  exit 0
fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "wsgrasp: installing libusb-1.0-0 (needed by open3d) with apt"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libusb-1.0-0 >/dev/null
else
  echo "wsgrasp: open3d needs the system library libusb-1.0. Install it with:" >&2
  echo "    sudo apt-get update && sudo apt-get install -y libusb-1.0-0" >&2
  exit 1
fi
