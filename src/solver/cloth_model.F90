! SPDX-License-Identifier: BSD-2-Clause
!> The process model: the residual F(t, U, Udot) and its Jacobian, PETSc's
!> IFunction and IJacobian callbacks (docs/model.md sections 5 and 6). Its
!> records, app_ctx%model and app_ctx%asm, are module model_state's, which
!> holds the residual on plain arrays and the 6-dof assembly.
!>
!> State: DMDA dof 6 per node, u(0:2) position, u(3:5) velocity;
!> F = [ xdot - v ; vdot - f(x, v)/m - g ] on free nodes and
!> F = [ xdot - vbar ; vdot ] on constrained nodes.
!> The rows are those of docs/model.md section 5 divided by the mass, so that
!> dF/dUdot = I: PETSc's ARKIMEX (explicit first stage) takes
!> Udot = -F(t, U, 0) and is wrong for any other form. A constrained node is
!> put on its path at the start of each time window (enter_window), where
!> its prescribed velocity is constant, so xdot = vbar keeps x = xbar(t)
!> exactly under every consistent integrator.
module cloth_model
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use kinds, only: rp
  use ghosted_state, only: ghosted_get, ghosted_restore
  use newton_control, only: floor_estimate
  use reduced, only: reduced_assemble
  use app_context, only: app_ctx
  use newton_state, only: newton_set_floor
  use model_state, only: model_residual, model_pm_jacobian, model_assemble_full
  use process_models, only: pm_list_on, pm_list_nodal
  use process_solver, only: pm_domain_error
  implicit none
  private
  public :: form_ifunction, form_ijacobian

contains

  !> F(t, U, Udot) (see the module header; module model_state's
  !> model_residual on the arrays, with the process models' forces); a
  !> state outside a process model's domain is SNES's domain error
  !> (module process_solver's pm_domain_error).
  subroutine form_ifunction(ts, t, uvec, udotvec, fvec, ctx, ierr)
    type(tTS) :: ts
    PetscReal :: t
    type(tVec) :: uvec, udotvec, fvec
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :), ud(:, :, :), fv(:, :, :)

    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, udotvec, ud, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, fvec, fv, ierr))
    call model_residual(ctx%model, ctx%lat, ctx%cs, ctx%pms, ctx%comm, t, u, ud, fv)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, fvec, fv, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, udotvec, ud, ierr))
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    if (pm_list_on(ctx%pms)) then
      PetscCall(pm_domain_error(ts, ctx, ierr))
    end if
  end subroutine form_ifunction

  !> dF/dU + a dF/dUdot: S of the reduced solve (module reduced), or the
  !> assembled 6-dof Jacobian (module model_state's model_assemble_full),
  !> whose round-off floor goes to Newton's record.
  subroutine form_ijacobian(ts, t, uvec, udotvec, a, jmat, pmat, ctx, ierr)
    type(tTS) :: ts
    PetscReal :: t, a
    type(tVec) :: uvec, udotvec
    type(tMat) :: jmat, pmat
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    type(tVec) :: uloc, udloc
    PetscScalar, pointer :: u(:, :, :), ud(:, :, :)
    real(rp) :: sums(2), gsums(2)
    logical :: pairs

    PetscCall(ghosted_get(ctx%da, uvec, uloc, u, ierr))
    ! the process models' blocks at this state, which both assemblies add
    if (pm_list_on(ctx%pms)) then
      ! pair blocks (self-contact) enter the reduced solve's S and
      ! right-hand side; the 6-dof assembly leaves them out (Newton is a
      ! quasi-Newton method there where pairs are active)
      call model_pm_jacobian(ctx%model, ctx%pms, ctx%lat, t, u, ctx%comm, pairs)
      if (pairs) then
        ierr = PETSC_ERR_SUP
        SETERRQ(ctx%comm, ierr, 'nuno: two process models gave blocks of node pairs; one can (src/model/process_models.f90)')
      end if
    end if
    if (ctx%use_reduced) then
      PetscCall(ghosted_get(ctx%da, udotvec, udloc, ud, ierr))
      PetscCall(reduced_assemble(ctx%red, u, ud, a, ierr))
      PetscCall(ghosted_restore(ctx%da, udloc, ud, ierr))
      PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
      PetscCall(MatAssemblyBegin(jmat, MAT_FINAL_ASSEMBLY, ierr))
      PetscCall(MatAssemblyEnd(jmat, MAT_FINAL_ASSEMBLY, ierr))
      return
    end if
    PetscCall(model_assemble_full(ctx%model, ctx%asm, ctx%lat, pm_list_nodal(ctx%pms), u, a, pmat, sums, ierr))
    PetscCall(ghosted_restore(ctx%da, uloc, u, ierr))
    call MPI_Allreduce(sums(1), gsums(1), 1, MPI_DOUBLE_PRECISION, MPI_SUM, ctx%comm, ierr)
    call MPI_Allreduce(sums(2), gsums(2), 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    call newton_set_floor(ctx%newton, floor_estimate(gsums))
    PetscCall(MatAssemblyBegin(pmat, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatAssemblyEnd(pmat, MAT_FINAL_ASSEMBLY, ierr))
    if (jmat%v /= pmat%v) then
      PetscCall(MatAssemblyBegin(jmat, MAT_FINAL_ASSEMBLY, ierr))
      PetscCall(MatAssemblyEnd(jmat, MAT_FINAL_ASSEMBLY, ierr))
    end if
  end subroutine form_ijacobian

end module cloth_model
