#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-2-Clause
# The main job: install, build, run the report's Fig. 3 scene (lift_release)
# on 2 ranks, then plot it. Output in runs/lift_release/.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bash "$here/install.sh"
bash "$here/build.sh"
source "$here/env.sh"
out="$NUNO_ROOT/runs/lift_release"
mkdir -p "$out"
cd "$out"
mpiexec -n 2 "$NUNO_ROOT/build/nuno" "$NUNO_ROOT/input/lift_release.nml" "$@"
cd "$NUNO_ROOT"
python3 -m postprocess.snapshots "$out/lift_release.h5" --view side -o "$out/snapshots.png"
python3 -m postprocess.timeseries "$out/lift_release.h5" -o "$out/timeseries.png"
echo "plots: $out/snapshots.png $out/timeseries.png"
