! SPDX-License-Identifier: BSD-2-Clause
!> -identify_check_gradient, -control_check_gradient: the adjoint gradient
!> of an identification or a control against central differences of its
!> objective (docs/identification.md).
module identify_check
#include "petsc/finclude/petscsys.h"
  use petscsys
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use timestepping, only: app_ctx
  use identify_params, only: ident_params_t, MODE_CONTROL, params_mode, params_tag, params_np, params_initial, &
                             params_fd_step, var_name, check_direction
  use identify_adjoint, only: ident_core_t, forward, objective_gradient, failed_run, core_app, core_params, &
                              run_trajectory
  implicit none
  private
  public :: check_gradient

contains

  !> -identify_check_gradient (-control_check_gradient): the adjoint
  !> gradient at the initial guess against central differences of the
  !> objective (step fd_step; second order for identification, fourth
  !> order for control), one line per direction on rank 0, and the
  !> measured costs. Identification: each ln p. Control: each optimised
  !> component of each keyframe position m = 2..nk (identify_params'
  !> check_direction).
  subroutine check_gradient(id, ierr, errmsg)
    class(ident_core_t), intent(inout), target :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp), allocatable :: g(:), theta0(:)
    real(rp) :: f, tf, wall0, mem_bytes, file_bytes
    integer :: k, nsteps
    type(ident_params_t), pointer :: par
    type(app_ctx), pointer :: app

    par => core_params(id)
    app => core_app(id)
    theta0 = params_initial(par)
    allocate(g(size(theta0)))
    wall0 = MPI_Wtime()
    call forward(id, theta0, f, ierr)
    if (ierr /= 0) return
    tf = MPI_Wtime() - wall0
    wall0 = MPI_Wtime()
    call objective_gradient(id, theta0, f, g, ierr)
    if (ierr /= 0) return
    if (failed_run(id, theta0, errmsg, ierr)) return
    if (app%rank == 0) then
      call run_trajectory(id, mem_bytes, file_bytes, nsteps)
      write(output_unit, '(a,es24.16)') params_tag(par)//': objective ', f
      write(output_unit, '(a,es12.4,a,es12.4,a,f7.3,2(a,es12.4),a,i0,a)') params_tag(par)//': cost forward_s ', tf, &
        ' gradient_s ', MPI_Wtime() - wall0, ' ratio ', (MPI_Wtime() - wall0) / tf, &
        ' trajectory_memory_bytes ', mem_bytes, ' trajectory_file_bytes ', file_bytes, ' steps ', nsteps, &
        ' (gradient = forward + adjoint)'
    end if
    do k = 1, params_np(par)
      call check_direction_line(id, par, theta0, g, k, errmsg, ierr)
      if (ierr /= 0) return
    end do
    if (app%rank == 0) flush(output_unit)
  end subroutine check_gradient

  !> One direction of the check: the adjoint's derivative along
  !> check_direction(k) against the central difference of the objective
  !> (fourth order for control: in-plane steps stretch links, and the
  !> second-order one's truncation error, measured 1e-4 relative at a step
  !> of 1e-5 lx, 1e-6 at 1e-6 lx where round-off begins, would hide an
  !> error of the adjoint); a line on rank 0.
  subroutine check_direction_line(id, par, theta0, g, k, errmsg, ierr)
    class(ident_core_t), intent(inout) :: id
    type(ident_params_t), intent(in) :: par
    real(rp), intent(in) :: theta0(:), g(:)
    integer, intent(in) :: k
    character(*), intent(out) :: errmsg
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: fp, fm, f2p, f2m, dir(size(theta0)), gd, fd, h
    type(app_ctx), pointer :: app

    app => core_app(id)
    h = params_fd_step(par)
    dir = check_direction(par, k)
    gd = dot_product(g, dir)
    call forward(id, theta0 + h * dir, fp, ierr)
    if (ierr /= 0) return
    call forward(id, theta0 - h * dir, fm, ierr)
    if (ierr /= 0) return
    if (failed_run(id, theta0, errmsg, ierr)) return
    fd = (fp - fm) / (2.0_rp * h)
    if (params_mode(par) == MODE_CONTROL) then
      call forward(id, theta0 + 2.0_rp * h * dir, f2p, ierr)
      if (ierr /= 0) return
      call forward(id, theta0 - 2.0_rp * h * dir, f2m, ierr)
      if (ierr /= 0) return
      if (failed_run(id, theta0, errmsg, ierr)) return
      fd = (8.0_rp * (fp - fm) - (f2p - f2m)) / (12.0_rp * h)
    end if
    if (app%rank == 0) write(output_unit, '(a,a,a,es24.16,a,es24.16,a,es10.3)') params_tag(par)//': gradient ', &
      trim(var_name(par, k)), ' adjoint ', gd, ' fd ', fd, ' relerr ', abs(gd - fd) / max(abs(fd), tiny(1.0_rp))
  end subroutine check_direction_line

end module identify_check
