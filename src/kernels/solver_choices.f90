! SPDX-License-Identifier: BSD-2-Clause
!> The choices of nuno's enumerated solver options, defined once: each
!> option's integer codes and, in the same order, its names (a name's
!> position from 0 is its code). The options blocks in C
!> (src/solver/nuno_options.c), which put the options in -help and check a
!> value, get the names from here as arguments and hand back a position;
!> the modules compare the codes. No list is spelled out anywhere else. No PETSc: unit-tested alone
!> (tests/unit/test_solver_choices.f90).
module solver_choices
  implicit none
  private
  public :: JACOBIAN_REDUCED, JACOBIAN_FULL, JACOBIAN_NAMES
  public :: INTERP_AUTO, INTERP_LINEAR, INTERP_CUBIC, INTERP_COARSE_CUBIC, INTERP_NAMES
  public :: GUESS_AUTO, GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, GUESS_PROJECT, GUESS_NAMES
  public :: FALLBACK_NONE, FALLBACK_BT, FALLBACK_L2, FALLBACK_NAMES
  public :: START_AUTO, START_LINEAR, START_CUBIC, START_CONSISTENT, START_NAMES
  public :: MG_STENCIL, MG_PETSC, MG_NAMES
  public :: CYCLE_V, CYCLE_KASKADE, CYCLE_W, CYCLE_NAMES
  public :: PRODUCT_MIXED, PRODUCT_DOUBLE, PRODUCT_FUSED, PRODUCT_NAMES
  public :: COARSE_AUTO, COARSE_REDISCRETIZE, COARSE_GALERKIN, COARSE_NAMES
  public :: GATHER_AUTO, GATHER_NEVER, GATHER_NAMES

  !> -nuno_jacobian: the reduced 3-dof elimination (module reduced) or the
  !> assembled 6-dof Jacobian.
  integer, parameter :: JACOBIAN_REDUCED = 0, JACOBIAN_FULL = 1
  character(len=*), parameter :: JACOBIAN_NAMES(0:1) = [character(len=7) :: 'reduced', 'full']

  !> -nuno_mg_interpolation: the multigrid's interpolation between levels
  !> (module reduced_mg); auto: cubic on the coarse levels with bending,
  !> linear without.
  integer, parameter :: INTERP_AUTO = 0, INTERP_LINEAR = 1, INTERP_CUBIC = 2, INTERP_COARSE_CUBIC = 3
  character(len=*), parameter :: INTERP_NAMES(0:3) = [character(len=12) :: 'auto', 'linear', 'cubic', 'coarse_cubic']

  !> -nuno_inner_guess: the inner solve's initial guess (kernel inner_guess).
  integer, parameter :: GUESS_AUTO = 0, GUESS_NONE = 1, GUESS_PREVIOUS = 2, GUESS_EXTRAPOLATE = 3, GUESS_PROJECT = 4
  character(len=*), parameter :: GUESS_NAMES(0:4) = [character(len=11) :: 'auto', 'none', 'previous', 'extrapolate', &
                                                      'project']

  !> -nuno_linesearch_fallback: the line search once a Newton solve has
  !> failed (module newton_policy); the names are PETSc's line-search types.
  integer, parameter :: FALLBACK_NONE = 0, FALLBACK_BT = 1, FALLBACK_L2 = 2
  character(len=*), parameter :: FALLBACK_NAMES(0:2) = [character(len=4) :: 'none', 'bt', 'l2']

  !> -nuno_newton_start: beuler's Newton start (module newton_start).
  !> consistent: the cubic start with its positions x_n + dt v (docs/performance.md, open problem 6)
  integer, parameter :: START_AUTO = 0, START_LINEAR = 1, START_CUBIC = 2, START_CONSISTENT = 3
  character(len=*), parameter :: START_NAMES(0:3) = [character(len=10) :: 'auto', 'linear', 'cubic', 'consistent']

  !> -nuno_mg: the inner multigrid where one fits and -reduced_pc_type is
  !> not given (module reduced): nuno's structured one (module stencil_mg)
  !> or PETSc's PCMG with Galerkin operators.
  integer, parameter :: MG_STENCIL = 0, MG_PETSC = 1
  character(len=*), parameter :: MG_NAMES(0:1) = [character(len=7) :: 'stencil', 'petsc']

  !> -nuno_mg_cycle: the cycle of nuno's multigrid (module stencil_mg): a
  !> V-cycle (multiplicative), kaskade (only upwards) or a W-cycle (two
  !> cycles on each coarser level per visit).
  integer, parameter :: CYCLE_V = 0, CYCLE_KASKADE = 1, CYCLE_W = 2
  character(len=*), parameter :: CYCLE_NAMES(0:2) = [character(len=7) :: 'v', 'kaskade', 'w']

  !> -nuno_mg_product: the Krylov method's product with S where nuno's
  !> multigrid is used (module reduced_mg): from the multigrid's
  !> single-precision S (mixed), from S in double precision (double), or
  !> mixed and formed in each cycle's last sweep (fused).
  integer, parameter :: PRODUCT_MIXED = 0, PRODUCT_DOUBLE = 1, PRODUCT_FUSED = 2
  character(len=*), parameter :: PRODUCT_NAMES(0:2) = [character(len=6) :: 'mixed', 'double', 'fused']

  !> -nuno_mg_coarse: how nuno's multigrid makes its coarse levels (module
  !> reduced_mg): the cloth rediscretised on the coarse lattice (module
  !> mg_coarse) or Galerkin products P^T A P (module stencil_mg); auto:
  !> rediscretised with bending, Galerkin without.
  integer, parameter :: COARSE_AUTO = 0, COARSE_REDISCRETIZE = 1, COARSE_GALERKIN = 2
  character(len=*), parameter :: COARSE_NAMES(0:2) = [character(len=12) :: 'auto', 'rediscretize', 'galerkin']

  !> -nuno_mg_gather: where a level of nuno's multigrid is too thin for
  !> the strips of more than 4 ranks, gather it on fewer (auto; module
  !> mg_gather) or make it the coarsest, replicated on every rank (never).
  integer, parameter :: GATHER_AUTO = 0, GATHER_NEVER = 1
  character(len=*), parameter :: GATHER_NAMES(0:1) = [character(len=5) :: 'auto', 'never']

end module solver_choices
