! SPDX-License-Identifier: BSD-2-Clause
!> When a Newton solve of a time step has converged at the round-off floor
!> of its residual: one rule for both Newton steps, the reduced 3-dof
!> elimination and the assembled 6-dof Jacobian (both assemblies estimate
!> the floor with floor_node_add and floor_estimate; module newton_state
!> applies floor_verdict in the convergence test, newton_policy's
!> snes_converged). Plain numbers in and out: unit-tested alone
!> (tests/unit/test_newton_control.f90).
!>
!> The residual F = [xdot - v ; vdot - f/m - g] (per unit mass) cannot go
!> below about eps max|x| (sum_i (K_ii/m_i)^2 + 3 a^2 n)^(1/2): a position
!> is known to eps |x|, the v-rows amplify that by the stiffness over the
!> mass K_ii/m_i (the stiffest, bending, grows like N^4 on a refined
!> lattice), the x-rows (a (x - x_n) - v) by the shift a = 1/dt. Below it a
!> Newton update is noise: a full step leaves ||F|| where it was, and a
!> backtracking line search (bt, the 6-dof path's default) finds no step
!> that decreases ||F|| and fails, which without this rule failed the time
!> step (hang 21 x 21 on the 6-dof path with LU: ||F|| stuck at 2.4e-9 from
!> t = 0.03 s on, eight retried steps, the run failed at t = 0.08 s).
module newton_control
  use kinds, only: rp
  implicit none
  private
  public :: FLOOR_FACTOR, STAGNATION, NEWTON_ITERATE, NEWTON_CONVERGED, NEWTON_DIVERGED
  public :: floor_node_add, floor_estimate, floor_verdict, update_at_floor, UPDATE_FLOOR, FLOOR_SLACK

  !> Fraction of the estimated round-off floor of ||F|| below which Newton
  !> has converged. The estimate was 14 times the floor actually met early
  !> in a run (hang 129..513), 3 times once the cloth swings (hang 257 x 257
  !> at t = 0.45 s): with a quarter, every step there took a third Newton
  !> iteration only to see the residual stall (docs/performance.md).
  real(rp), parameter :: FLOOR_FACTOR = 0.5_rp
  !> An iteration that reduces ||F|| by less than 10 % has stagnated.
  real(rp), parameter :: STAGNATION = 0.9_rp
  !> update_at_floor: an update shorter than UPDATE_FLOOR ||u|| (2-norms)
  !> moves the state by no more than round-off amplified by the Jacobian's
  !> inverse (a 7 x 7 sheet at its floor: full updates of 6e-12 ||u||),
  !> and a residual within FLOOR_SLACK of the floor's estimate is at the
  !> floor as far as that estimate can tell (it was 1/14 to 1.5 times the
  !> floor met).
  real(rp), parameter :: UPDATE_FLOOR = 1.0e-10_rp, FLOOR_SLACK = 100.0_rp
  !> floor_verdict's answers.
  integer, parameter :: NEWTON_ITERATE = 0, NEWTON_CONVERGED = 1, NEWTON_DIVERGED = -1

contains

  !> Add one free node to the sums of the floor estimate: sums(1) gets
  !> sum_q (kd(q)/mass)^2 + 3 a^2 [1/time^4], sums(2) the max of |x(q)|
  !> [length]. kd: the diagonal of the node's own stiffness block
  !> dforce/dx [force/length]; mass [mass]; a: the shift dF/dUdot [1/time].
  !> Constrained nodes are left out (their rows are a (x - xbar(t)), exact).
  pure subroutine floor_node_add(kd, mass, x, a, sums)
    real(rp), intent(in) :: kd(3), mass, x(3), a
    real(rp), intent(inout) :: sums(2)
    sums(1) = sums(1) + sum((kd / mass)**2) + 3.0_rp * a**2
    sums(2) = max(sums(2), maxval(abs(x)))
  end subroutine floor_node_add

  !> The round-off floor of ||F||_2 from the sums of floor_node_add over all
  !> nodes (sums(1) added, sums(2) the max over the ranks).
  pure real(rp) function floor_estimate(sums) result(floor)
    real(rp), intent(in) :: sums(2)
    floor = epsilon(1.0_rp) * sums(2) * sqrt(max(sums(1), 0.0_rp))
  end function floor_estimate

  !> Verdict on Newton iteration k >= 1 with residual fnorm (the previous
  !> one fnorm_prev, the solve's first fnorm0), by the round-off floor:
  !>  (a) converged: below stagnant = max(snes_floor fnorm0, floor_est) and
  !>      reduced by less than 10 % (stagnation at the floor);
  !>  (b) converged: below FLOOR_FACTOR floor_est (saves the iteration
  !>      that (a) needs to see the stall);
  !>  (c) ls_failed (the line search found no step that decreases ||F||;
  !>      fnorm is then the residual before it): converged when below
  !>      stagnant, as (a) would have said after a full step; else
  !>      diverged, as PETSc's own test says.
  !> snes_floor = 0 turns (a)-(c) off (a failed line search diverges).
  !> Otherwise: iterate.
  pure integer function floor_verdict(fnorm, fnorm_prev, fnorm0, snes_floor, floor_est, ls_failed) result(v)
    real(rp), intent(in) :: fnorm, fnorm_prev, fnorm0, snes_floor, floor_est
    logical, intent(in) :: ls_failed
    real(rp) :: stagnant
    v = NEWTON_ITERATE
    if (.not. (snes_floor > 0.0_rp)) then
      if (ls_failed) v = NEWTON_DIVERGED
      return
    end if
    ! (with a good start, e.g. the extrapolated one of beuler, ||F_0|| is
    ! small and snes_floor ||F_0|| fell below the floor itself: hang
    ! 257 x 257 stalled at 1.3e-3 > 1e-6 ||F_0|| = 8.6e-4 for 50 iterations)
    stagnant = max(snes_floor * fnorm0, floor_est)
    if (ls_failed) then
      v = merge(NEWTON_CONVERGED, NEWTON_DIVERGED, fnorm <= stagnant)
    else if (fnorm <= stagnant .and. fnorm > STAGNATION * fnorm_prev) then
      v = NEWTON_CONVERGED
    else if (fnorm <= FLOOR_FACTOR * floor_est) then
      v = NEWTON_CONVERGED
    end if
  end function floor_verdict

  !> Converged at the floor, by the update rather than the residual alone
  !> (Newton iteration k >= 1): the iteration reduced ||F|| by less than
  !> 10 % (fnorm > STAGNATION fnorm_prev) with an update snorm <=
  !> UPDATE_FLOOR xnorm and a residual below FLOOR_SLACK floor_est. It
  !> needs no line search: a start at the floor (the cubic start of a
  !> sheet in free fall, exact up to round-off) is where floor_verdict's
  !> test, which needs fnorm below floor_est, can miss the floor met (a
  !> 7 x 7 sheet: ||F|| stalled at 5.9e-10 against the estimate 3.9e-10,
  !> full updates of 6e-12 ||u||; the fallback line search bt crept on by
  !> 1 % an iteration to the iteration limit).
  pure logical function update_at_floor(fnorm, fnorm_prev, snorm, xnorm, floor_est)
    real(rp), intent(in) :: fnorm, fnorm_prev   !< ||F|| now and at the iteration before [residual]
    real(rp), intent(in) :: snorm, xnorm        !< ||update|| and ||state|| (2-norms, the same units)
    real(rp), intent(in) :: floor_est           !< round-off floor's estimate (floor_estimate) [residual]
    update_at_floor = fnorm > STAGNATION * fnorm_prev .and. snorm <= UPDATE_FLOOR * xnorm .and. &
                      fnorm <= FLOOR_SLACK * floor_est
  end function update_at_floor

end module newton_control
