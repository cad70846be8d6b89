#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# Install what nuno needs on Debian 12: compilers, Open MPI, PETSc 3.18,
# parallel HDF5, ParaView's Python for the XDMF test (apt) and the Python
# packages of postprocess/ and the tests, pyvista and xarray included (pip).
# Idempotent; prints nothing on success, the failing log otherwise.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
log=$(mktemp)
trap 'rm -f "$log"' EXIT

sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
debs=(gfortran gcc make cmake pkg-config openmpi-bin libopenmpi-dev petsc-dev libhdf5-openmpi-dev liblapack-dev python3 python3-pip)
missing=()
for p in "${debs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if ! { $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}"; } >"$log" 2>&1; then
    cat "$log" >&2
    echo "install.sh: apt-get install failed for: ${missing[*]}" >&2
    exit 1
  fi
fi

# ParaView (5.11, pvpython), whose XDMF reader tests/python/test_xdmf.py
# opens the XDMF sidecar with: without recommends, about 220 MB to download,
# 1.1 GB installed, a minute on a fresh machine.
if ! dpkg-query -W -f='${Status}' python3-paraview 2>/dev/null | grep -q "install ok installed"; then
  # (the package lists are fresh when the block above just installed something)
  if ! { { [ ${#missing[@]} -gt 0 ] || $sudo apt-get update -qq; } && \
         DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends python3-paraview; \
       } >"$log" 2>&1; then
    cat "$log" >&2
    echo "install.sh: apt-get install failed for: python3-paraview" >&2
    exit 1
  fi
fi

# pyvista (with VTK's wheel), xarray and h5netcdf: the readers that
# tests/python/test_readers.py opens the output with, as users do.
if ! python3 -c "import numpy, h5py, matplotlib, PIL, pytest, setuptools, wheel, f90nml, scipy, pyvista, xarray, h5netcdf" \
     >/dev/null 2>&1; then
  if ! python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore \
       -r "$here/requirements.txt" >"$log" 2>&1; then
    # Debian's own python3 refuses system-wide pip installs (PEP 668).
    if ! python3 -m pip install --quiet --disable-pip-version-check --break-system-packages \
         -r "$here/requirements.txt" >"$log" 2>&1; then
      cat "$log" >&2
      echo "install.sh: pip install failed" >&2
      exit 1
    fi
  fi
fi
