#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# The multigrid kernels alone (bench/mg_micro.f90), built here with the
# Release flags: bash bench/mg_micro.sh [N (257)] [reach (2)] [lines|square] [paired]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
k=$root/src/kernels b=$root/src/base
cd "$work"
flags=(-O3 -march=native -ffree-line-length-none)
[ "$(uname -m)" = x86_64 ] && flags+=(-mprefer-vector-width=512)
gfortran "${flags[@]}" -c "$b/kinds.f90" "$k/interpolation.f90" "$k/offset_product.f90" "$k/mg_stencil.f90" "$k/mg_transfer.f90" "$k/mg_kernels.f90"
gfortran "${flags[@]}" "$root/bench/mg_micro.f90" ./*.o -o mg_micro
./mg_micro "${1:-257}" "${2:-2}" "${3:-lines}" ${4:+"$4"}
