# SPDX-License-Identifier: BSD-2-Clause
# Sourced by bench/ab_cpu.sh and bench/assembly_cpu.sh: the hang case of
# their arguments N BENDING MODE STEPS, in a fresh temporary folder that is
# removed on exit (the caller's working folder then): m.nml there, and
# the mode's options in the array mo.
# BENDING: energy | none; MODE: bw (ksponly, rtol 1e-3, dt 1/600) | newton (dt 1e-3)
hang_case() {
  local n=$1 bend=$2 mode=$3 steps=$4 dt tend
  dt=0.001; [ "$mode" = bw ] && dt=0.0016666666666666668
  tend=$(python3 -c "print($steps*$dt)")
  d=$(mktemp -d); trap 'rm -rf "$d"' EXIT; cd "$d"
  cat > m.nml <<EON
&scene scene_name='hang' /
&lattice nx=$n, ny=$n /
&material bending_model='$bend' /
&time t_end=$tend, dt=$dt /
&output output_interval=$tend, output_file='m.h5' /
EON
  mo=()
  # an if, not [ ] && ...: the function's status is its last command's, and
  # the callers run under set -e (newton mode ended them silently)
  if [ "$mode" = bw ]; then mo=(-snes_type ksponly -reduced_ksp_rtol 1e-3); fi
}
