! SPDX-License-Identifier: BSD-2-Clause
!> When to rebuild a reused inner preconditioner (-nuno_pc_lag,
!> -nuno_pc_rebuild_growth; docs/design.md, "Preconditioner reuse").
!> Plain numbers in and out: unit-tested alone (tests/unit/test_pc_reuse.f90).
!>
!> The reduced solve keeps its preconditioner (nuno's multigrid: the coarse
!> levels; its finest level always uses the current S) for up to lag
!> assemblies. Kept too long, its coarse correction ages and the cycles a
!> solve grow. The safeguard measures each converged solve's cycles per
!> decade of residual reduction, its / log10(1/rtol) (rtol: the solve's
!> own relative tolerance, which FGMRES reached when it converged by it),
!> against the first such solve after the last rebuild, and asks for a
!> rebuild at the next assembly when the ratio passes growth. Cycles per
!> decade, not cycles, because the Newton forcing changes rtol from solve to
!> solve; only solves of at least MIN_DECADES decades count, where one
!> cycle more or less is not already a large ratio.
module pc_reuse
  use kinds, only: rp
  use solver_choices, only: INTERP_LINEAR
  implicit none
  private
  public :: pc_reuse_t, reuse_init, reuse_due, reuse_rebuilt, reuse_force, reuse_watch, reuse_grown
  public :: cycles_per_decade, default_pc_lag, MIN_DECADES, PC_GROWTH_DEFAULT, PAIRS_PC_LAG

  !> -nuno_pc_rebuild_growth's default (docs/performance.md, "Reuse across steps")
  real(rp), parameter :: PC_GROWTH_DEFAULT = 1.5_rp

  !> The longest lag while S has pair blocks (self-contact's pairs in the
  !> barrier; docs/performance.md, "Self-contact"): their stiffness, kappa
  !> over the gap squared, changes by orders from step to step where the
  !> layers meet, and the coarse levels hold only the node blocks of their
  !> last rebuild. bw at 129 x 129 where the halves meet: 17.6 cycles a
  !> solve with the cubic interpolation's lag of 20, 8.2 with 3, 7.6 with
  !> 1 (the safeguard misses it: the first solve after a rebuild is
  !> already slow, and becomes its reference).
  integer, parameter :: PAIRS_PC_LAG = 3

  !> a solve counts when its rtol is at most 10^-MIN_DECADES
  real(rp), parameter :: MIN_DECADES = 2.0_rp

  !> The reuse state of one preconditioner.
  type :: pc_reuse_t
    private
    integer :: lag = 1                 !< rebuild at least every lag assemblies (>= 1)
    integer :: since = 0               !< assemblies since the last rebuild
    real(rp) :: growth = 0.0_rp        !< rebuild when cycles per decade pass growth x the reference (0: off)
    real(rp) :: ref = 0.0_rp           !< cycles per decade of the first counted solve after the last rebuild (0: none yet)
    logical :: grown = .false.         !< a solve since the last rebuild passed growth x ref
    integer :: n_grown = 0             !< rebuilds the safeguard asked for (reuse_grown; read by tests/unit/test_pc_reuse only, no run report prints it)
  end type pc_reuse_t

contains

  !> lag >= 1 assemblies; growth 0 (off) or > 1. The first assembly rebuilds.
  pure subroutine reuse_init(r, lag, growth)
    type(pc_reuse_t), intent(out) :: r
    integer, intent(in) :: lag
    real(rp), intent(in) :: growth
    r%lag = max(lag, 1)
    r%growth = growth
    r%since = r%lag
  end subroutine reuse_init

  !> At an assembly: whether to rebuild now (the lag reached, PAIRS_PC_LAG
  !> reached while S has pair blocks, or the safeguard asked); counts the
  !> assembly.
  pure subroutine reuse_due(r, pairs, due)
    type(pc_reuse_t), intent(inout) :: r
    logical, intent(in) :: pairs       !< S has pair blocks now (the same on every rank)
    logical, intent(out) :: due
    r%since = r%since + 1
    due = r%since >= r%lag .or. r%grown .or. (pairs .and. r%since >= PAIRS_PC_LAG)
  end subroutine reuse_due

  !> The preconditioner was just rebuilt: start the count and the reference afresh.
  pure subroutine reuse_rebuilt(r)
    type(pc_reuse_t), intent(inout) :: r
    if (r%grown) r%n_grown = r%n_grown + 1
    r%since = 0
    r%ref = 0.0_rp
    r%grown = .false.
  end subroutine reuse_rebuilt

  !> Rebuild at the next assembly whatever the count (new constraints, a restart point).
  pure subroutine reuse_force(r)
    type(pc_reuse_t), intent(inout) :: r
    r%since = r%lag
  end subroutine reuse_force

  !> A solve converged by its relative tolerance rtol in its cycles
  !> (by_rtol false: by another test, which says nothing of the rate).
  pure subroutine reuse_watch(r, its, rtol, by_rtol)
    type(pc_reuse_t), intent(inout) :: r
    integer, intent(in) :: its
    real(rp), intent(in) :: rtol
    logical, intent(in) :: by_rtol
    real(rp) :: c
    if (r%growth <= 0.0_rp .or. .not. by_rtol .or. its < 1) return
    if (.not. (rtol > 0.0_rp .and. rtol <= 10.0_rp**(-MIN_DECADES))) return
    c = cycles_per_decade(its, rtol)
    if (r%ref <= 0.0_rp) then
      r%ref = c
    else if (c > r%growth * r%ref) then
      r%grown = .true.
    end if
  end subroutine reuse_watch

  !> Rebuilds the safeguard has asked for so far.
  pure integer function reuse_grown(r)
    type(pc_reuse_t), intent(in) :: r
    reuse_grown = r%n_grown
  end function reuse_grown

  !> its cycles that reduced the residual by rtol (0 < rtol < 1): cycles a decade.
  pure real(rp) function cycles_per_decade(its, rtol) result(c)
    integer, intent(in) :: its
    real(rp), intent(in) :: rtol
    c = real(its, rp) / log10(1.0_rp / rtol)
  end function cycles_per_decade

  !> The inner preconditioner's rebuild interval: pc_lag where given (> 0),
  !> else the default, measured (commits e0d6262, 458d4d3 and 53c2cdd):
  !> a multigrid's (mg: nuno's or PCMG) Galerkin coarse operators kept
  !> for 3 assemblies, 20 with the cubic interpolation, whose products
  !> cost about five times more (its fine-level smoother and residual
  !> always use the current S, so only the coarse correction ages; 20
  !> against 10: the same inner iterations on hang's 1 s, 1-4 % more on
  !> the release scenes, half the rebuilds), any other preconditioner
  !> rebuilt each time.
  pure integer function default_pc_lag(pc_lag, mg, interp) result(lag)
    integer, intent(in) :: pc_lag
    logical, intent(in) :: mg
    integer, intent(in) :: interp          !< the multigrid's interpolation (INTERP_*)
    if (pc_lag > 0) then
      lag = pc_lag
    else if (mg .and. interp /= INTERP_LINEAR) then
      lag = 20
    else if (mg) then
      lag = 3
    else
      lag = 1
    end if
  end function default_pc_lag

end module pc_reuse
