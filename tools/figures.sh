#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# The report's Figs. 3-5: build nuno if needed, run the three scenes with the
# paper and the energy bending models into runs/report/, write
# runs/figures/fig{3,4,5}_*.png (--outdir docs/figures to update the tracked
# figures of the documentation). Arguments go to postprocess.report_figures
# (nuno-report-figures: e.g. --skip-run, --quick, --help).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/env.sh"
cd "$NUNO_ROOT"
if [[ ! -x build/nuno ]]; then
  echo "figures.sh: building nuno (tools/build.sh)"
  bash "$here/build.sh"
fi
exec python3 -m postprocess.report_figures "$@"
