#!/usr/bin/env bash
# Install the system packages fsph needs to build, when they are missing:
# a Fortran compiler (gfortran), a C compiler, Python's venv module and the
# Python headers. Uses apt-get (as root, or through sudo when available).
set -euo pipefail
PYTHON=${PYTHON:-python3}
need=()
command -v gfortran >/dev/null 2>&1 || need+=(gfortran)
command -v cc >/dev/null 2>&1 || need+=(gcc)
command -v "$PYTHON" >/dev/null 2>&1 || need+=(python3)
if command -v "$PYTHON" >/dev/null 2>&1; then
  "$PYTHON" -c 'import venv, ensurepip' >/dev/null 2>&1 || need+=(python3-venv)
  "$PYTHON" - <<'PY' >/dev/null 2>&1 || need+=(python3-dev)
import os, sys, sysconfig
sys.exit(0 if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)
PY
fi
[ ${#need[@]} -eq 0 ] && exit 0
echo "bootstrap: installing ${need[*]} with apt-get"
if [ "$(id -u)" -eq 0 ]; then
  SUDO=""
elif command -v sudo >/dev/null 2>&1; then
  SUDO="sudo"
else
  echo "bootstrap: need root (or sudo) to install: ${need[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq "${need[@]}"
