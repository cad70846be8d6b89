! SPDX-License-Identifier: BSD-2-Clause
!> Sane bounds of a run, checked before anything is allocated (module
!> input, input_check_run) and quoted by `nuno --help` (module
!> input_usage). No MPI, no PETSc.
module input_limits
  use kinds, only: rp
  implicit none
  private
  public :: max_steps, max_outputs, bytes_per_node_bending, bytes_per_node_plain

  !> More steps (t_end/dt) or output steps (t_end/output_interval) than
  !> this need -nuno_allow_long, so that a typo in dt (1e-12) does not start
  !> a job that cannot end.
  real(rp), parameter :: max_steps = 1.0e8_rp, max_outputs = 1.0e5_rp

  !> Memory a lattice node needs at least, on the leanest solver path, so
  !> that the memory check refuses only runs that cannot fit [bytes].
  !> Measured: peak RSS (/usr/bin/time -v) of one rank, hang scene, 3 fixed
  !> steps, default reduced Jacobian and multigrid, minus the peak of the
  !> same run at 17 x 17 (the per-process cost, ~51 MB), over nx ny:
  !>
  !>   bending  mode                 257 x 257   513 x 513
  !>   energy   Newton               4.24 KB     4.20 KB
  !>   energy   -snes_type ksponly   3.68 KB     3.63 KB
  !>   none     Newton               3.09 KB     3.03 KB
  !>   none     -snes_type ksponly   2.41 KB     2.41 KB
  !>
  !> (docs/performance.md, "Memory: bytes per node"; with bending the
  !> rediscretised coarse levels of the multigrid). The bounds are the
  !> smallest (ksponly: no Newton state; with bending 3.24 KB at 129 x 129,
  !> test_memory_estimate's lattice) less about 7-10 %; more ranks,
  !> Newton, adaptive steps and -nuno_jacobian full need more.
  !> tests/python/test_memory_estimate.py checks that a real run's peak
  !> stays above them.
  real(rp), parameter :: bytes_per_node_bending = 3000.0_rp, bytes_per_node_plain = 2200.0_rp

end module input_limits
