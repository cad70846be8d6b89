! SPDX-License-Identifier: BSD-2-Clause
!> The run's energy integrals (dissipated energy, work of the constraint
!> reactions), advanced by the TS monitor (module step_monitor) over each
!> accepted step so that they close at the method's order: Gauss-Legendre
!> on the interpolant of bdf (order up to 6), the trapezoid rule otherwise.
!> The record app_ctx%energy; this module is its only writer.
module energy_integrals
#include "petsc/finclude/petscvec.h"
  use petscvec
  use kinds, only: rp
  implicit none
  private
  public :: energy_integrals_t, energy_integrals_init, energy_integrals_free, energy_integrals_reset, &
            energy_integrals_start, energy_integrals_restore, energy_add_work, energy_set_mgx0
  public :: energy_gauss_time, energy_gauss_add, energy_trapezoid_add
  public :: energy_gauss, energy_t_prev, energy_work_vector, energy_totals, energy_powers_prev
  public :: energy_gauss_share, energy_gauss_at

  !> Gauss-Legendre points (on [0, 1]) and weights, 3 points: exact to
  !> degree 5, so the error is that of the interpolant, the method's order.
  real(rp), parameter :: GAUSS_X(3) = [0.5_rp - sqrt(0.15_rp), 0.5_rp, 0.5_rp + sqrt(0.15_rp)]
  real(rp), parameter :: GAUSS_W(3) = [5.0_rp / 18.0_rp, 8.0_rp / 18.0_rp, 5.0_rp / 18.0_rp]

  type :: energy_integrals_t
    private
    logical :: gauss = .false.                  !< Gauss-Legendre on the interpolant (bdf), else the trapezoid rule
    type(tVec) :: uq                            !< interpolated state (Gauss points)
    real(rp) :: t_prev = 0                      !< the last accepted step's time [time]
    real(rp) :: pdiss_prev = 0, pcon_prev = 0   !< its powers (trapezoid rule) [energy/time]
    real(rp) :: dissipated = 0                  !< dissipated energy [energy]
    real(rp) :: work_constraints = 0            !< work of the constraint reactions [energy]
    real(rp) :: mgx0 = 0                        !< sum m g . x at t = 0 [energy]
  end type energy_integrals_t

contains

  !> The integration rule (gauss: Gauss-Legendre on the interpolant, for
  !> bdf; else the trapezoid rule) and the work vector of its points, like
  !> the state u. Collective.
  subroutine energy_integrals_init(e, gauss, u, ierr)
    type(energy_integrals_t), intent(inout) :: e
    logical, intent(in) :: gauss
    type(tVec), intent(in) :: u                 !< the state (its layout)
    PetscErrorCode, intent(out) :: ierr
    e%gauss = gauss
    PetscCall(VecDuplicate(u, e%uq, ierr))
  end subroutine energy_integrals_init

  !> The interpolated state of the Gauss points. Collective.
  subroutine energy_integrals_free(e, ierr)
    type(energy_integrals_t), intent(inout) :: e
    PetscErrorCode, intent(out) :: ierr
    PetscCall(VecDestroy(e%uq, ierr))
  end subroutine energy_integrals_free

  !> The integrals back at their start (t = 0, nothing dissipated, no work
  !> done) for a new run over the same solver (identification, control);
  !> the integration rule and its work vector stay.
  subroutine energy_integrals_reset(e)
    type(energy_integrals_t), intent(inout) :: e
    e%t_prev = 0
    e%pdiss_prev = 0
    e%pcon_prev = 0
    e%dissipated = 0
    e%work_constraints = 0
    e%mgx0 = 0
  end subroutine energy_integrals_reset

  !> The integrals go on from t [time] (the run's start, a restart's
  !> checkpoint time, the step the monitor has just integrated): the next
  !> step integrates from there.
  subroutine energy_integrals_start(e, t)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: t
    e%t_prev = t
  end subroutine energy_integrals_start

  !> The integrals of a checkpoint [energy] (module run_checkpoint).
  subroutine energy_integrals_restore(e, dissipated, work_constraints, mgx0)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: dissipated, work_constraints, mgx0
    e%dissipated = dissipated
    e%work_constraints = work_constraints
    e%mgx0 = mgx0
  end subroutine energy_integrals_restore

  !> sum m g . x at t = 0 [energy], the reference of the potential energy
  !> of gravity in the external work (the output step at t = 0).
  subroutine energy_set_mgx0(e, mgx0)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: mgx0
    e%mgx0 = mgx0
  end subroutine energy_set_mgx0

  !> The work dw [energy] done on the cloth at a window's start (the
  !> impulse of a keyframe: enter_window) added to the constraint work.
  subroutine energy_add_work(e, dw)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: dw
    e%work_constraints = e%work_constraints + dw
  end subroutine energy_add_work

  !> The time [time] of Gauss point q (1..3) of the step of length h that
  !> ends the integrals' interval.
  pure real(rp) function energy_gauss_time(e, h, q)
    type(energy_integrals_t), intent(in) :: e
    real(rp), intent(in) :: h
    integer, intent(in) :: q
    energy_gauss_time = e%t_prev + h * GAUSS_X(q)
  end function energy_gauss_time

  !> Gauss point q's share of the step of length h [time]: p the dissipated
  !> power and the constraints' power there [energy/time].
  subroutine energy_gauss_add(e, h, q, p)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: h, p(2)
    integer, intent(in) :: q
    e%dissipated = e%dissipated + h * GAUSS_W(q) * p(1)
    e%work_constraints = e%work_constraints + h * GAUSS_W(q) * p(2)
  end subroutine energy_gauss_add

  !> The trapezoid rule over the step that ends at t, p the powers at t
  !> (the dissipated power and the constraints' power [energy/time]), kept
  !> for the next step.
  subroutine energy_trapezoid_add(e, t, p)
    type(energy_integrals_t), intent(inout) :: e
    real(rp), intent(in) :: t, p(2)
    if (t > e%t_prev) then
      e%dissipated = e%dissipated + 0.5_rp * (e%pdiss_prev + p(1)) * (t - e%t_prev)
      e%work_constraints = e%work_constraints + 0.5_rp * (e%pcon_prev + p(2)) * (t - e%t_prev)
    end if
    e%pdiss_prev = p(1)
    e%pcon_prev = p(2)
  end subroutine energy_trapezoid_add

  !> The share of Gauss point q (1..3) of an interval of length h [time]
  !> (the interval from an output time to the step's end: module
  !> step_monitor's integrals_after): [time].
  pure real(rp) function energy_gauss_share(h, q)
    real(rp), intent(in) :: h
    integer, intent(in) :: q
    energy_gauss_share = h * GAUSS_W(q)
  end function energy_gauss_share

  !> The time [time] of Gauss point q (1..3) of the interval of length h
  !> that starts at ta [time].
  pure real(rp) function energy_gauss_at(ta, h, q)
    real(rp), intent(in) :: ta, h
    integer, intent(in) :: q
    energy_gauss_at = ta + h * GAUSS_X(q)
  end function energy_gauss_at

  !> The powers at the time the integrals have reached (the trapezoid
  !> rule's last point): dissipated power and the constraints' power
  !> [energy/time].
  pure function energy_powers_prev(e) result(p)
    type(energy_integrals_t), intent(in) :: e
    real(rp) :: p(2)
    p = [e%pdiss_prev, e%pcon_prev]
  end function energy_powers_prev

  !> Gauss-Legendre on the interpolant (else the trapezoid rule).
  pure logical function energy_gauss(e)
    type(energy_integrals_t), intent(in) :: e
    energy_gauss = e%gauss
  end function energy_gauss

  !> The time the integrals have reached [time].
  pure real(rp) function energy_t_prev(e)
    type(energy_integrals_t), intent(in) :: e
    energy_t_prev = e%t_prev
  end function energy_t_prev

  !> The work vector of the Gauss points' interpolated states (the
  !> record keeps the handle; the caller fills the vector).
  function energy_work_vector(e) result(uq)
    type(energy_integrals_t), intent(in) :: e
    type(tVec) :: uq
    uq = e%uq
  end function energy_work_vector

  !> The integrals so far [energy]: the dissipated energy, the work of the
  !> constraint reactions, and sum m g . x at t = 0 (for a checkpoint, the
  !> output step's balance).
  pure subroutine energy_totals(e, dissipated, work_constraints, mgx0)
    type(energy_integrals_t), intent(in) :: e
    real(rp), intent(out) :: dissipated, work_constraints, mgx0
    dissipated = e%dissipated
    work_constraints = e%work_constraints
    mgx0 = e%mgx0
  end subroutine energy_totals

end module energy_integrals
