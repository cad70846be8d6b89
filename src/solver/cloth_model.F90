! SPDX-License-Identifier: BSD-2-Clause
!> The process model: the residual F(t, U, Udot) and its assembled
!> Jacobian, PETSc's IFunction and IJacobian callbacks (docs/model.md
!> sections 5 and 6).
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
  use forces, only: internal_forces, jac_buffer_row, slot_of, first_anchor_row, jac_buffer_init
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t, constraint_target
  use newton_control, only: floor_node_add, floor_estimate
  use reduced, only: reduced_assemble, set_block_row
  use app_context, only: app_ctx, model_state_t, assembly_t
  use newton_state, only: newton_set_floor
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use contact_forces, only: contact_on, contact_add_forces, contact_blocks, contact_move
  implicit none
  private
  public :: form_ifunction, form_ijacobian
  ! the model and assembly records of app_ctx: written only here
  public :: model_state_init, model_enter_window, model_state_free, assembly_create, assembly_free, &
            model_internal_forces

contains

  ! ---------------------------------------------------------------- callbacks

  !> F(t, U, Udot) (see the module header).
  subroutine form_ifunction(ts, t, uvec, udotvec, fvec, ctx, ierr)
    type(tTS) :: ts
    PetscReal :: t
    type(tVec) :: uvec, udotvec, fvec
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    type(tVec) :: uloc
    PetscScalar, pointer :: u(:, :, :), ud(:, :, :), fv(:, :, :)

    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, udotvec, ud, ierr))
    PetscCall(DMDAVecGetArrayF90(ctx%da, fvec, fv, ierr))
    call residual(ctx, t, u, ud, fv)
    PetscCall(DMDAVecRestoreArrayF90(ctx%da, fvec, fv, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, udotvec, ud, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
  end subroutine form_ifunction

  !> The residual on plain arrays. A singular element (zero-length link,
  !> bending triple at pi) makes the residual NaN, so that SNES fails the
  !> step collectively; ctx%model%nbad says why.
  subroutine residual(ctx, t, u, ud, fv)
    type(app_ctx), intent(inout) :: ctx
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:5, 0:ctx%lat%nx - 1, ctx%lat%gys:ctx%lat%gye)
    real(rp), intent(in) :: ud(0:5, 0:ctx%lat%nx - 1, ctx%lat%ys:ctx%lat%ye)
    real(rp), intent(out) :: fv(0:5, 0:ctx%lat%nx - 1, ctx%lat%ys:ctx%lat%ye)
    integer :: i, j, k, nbad, bad(2), ncross
    real(rp) :: xb(3), vb(3)

    call internal_forces(ctx%lat, u, ctx%model%f, nbad, bad)
    ncross = 0
    if (contact_on(ctx%contact)) then
      call contact_move(ctx%contact, t)    ! the obstacles at the stage time
      call contact_add_forces(ctx%contact, ctx%lat, ctx%model%fixed, u, ctx%model%f(:, :, ctx%lat%ys:ctx%lat%ye), ncross)
    end if
    do j = ctx%lat%ys, ctx%lat%ye
      do i = 0, ctx%lat%nx - 1
        fv(0:2, i, j) = ud(0:2, i, j) - u(3:5, i, j)
        fv(3:5, i, j) = ud(3:5, i, j) - ctx%model%f(:, i, j) / ctx%lat%mass(i, j) - ctx%model%gravity
      end do
    end do
    if (ctx%cs%active) then
      do k = 1, ctx%cs%n
        call constraint_target(ctx%cs, k, t, xb, vb)
        i = ctx%cs%node(1, k)
        j = ctx%cs%node(2, k)
        fv(0:2, i, j) = ud(0:2, i, j) - vb
        fv(3:5, i, j) = ud(3:5, i, j)
      end do
    end if
    if (nbad > 0) then
      ctx%model%nbad = nbad
      ctx%model%bad = bad
      ctx%model%t_bad = t
      fv(0, 0, ctx%lat%ys) = ieee_value(1.0_rp, ieee_quiet_nan)
    end if
    ! a state inside an obstacle (module contact_solver): the step fails and is retried smaller
    if (ncross > 0) fv(0, 0, ctx%lat%ys) = ieee_value(1.0_rp, ieee_quiet_nan)
  end subroutine residual

  !> dF/dU + a dF/dUdot (v-rows: -K/m and a I - C/m), assembled row by row from the rolling buffer of
  !> element blocks: one MatSetValuesBlockedLocal per node, INSERT_VALUES
  !> over the whole preallocated stencil (so no MatZeroEntries is needed).
  subroutine form_ijacobian(ts, t, uvec, udotvec, a, jmat, pmat, ctx, ierr)
    type(tTS) :: ts
    PetscReal :: t, a
    type(tVec) :: uvec, udotvec
    type(tMat) :: jmat, pmat
    type(app_ctx) :: ctx
    PetscErrorCode :: ierr
    type(tVec) :: uloc, udloc
    PetscScalar, pointer :: u(:, :, :), ud(:, :, :)
    integer :: ja, i, q
    real(rp) :: kd(3), sums(2), gsums(2)

    PetscCall(DMGetLocalVector(ctx%da, uloc, ierr))
    PetscCall(DMGlobalToLocalBegin(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMGlobalToLocalEnd(ctx%da, uvec, INSERT_VALUES, uloc, ierr))
    PetscCall(DMDAVecGetArrayReadF90(ctx%da, uloc, u, ierr))
    ! contact's diagonal blocks at this state, which both assemblies add (lattice_t's nodal)
    if (contact_on(ctx%contact)) then
      call contact_move(ctx%contact, t)
      call contact_blocks(ctx%contact, ctx%lat, ctx%model%fixed, u, ctx%lat%nodal)
    end if
    if (ctx%use_reduced) then
      PetscCall(DMGetLocalVector(ctx%da, udloc, ierr))
      PetscCall(DMGlobalToLocalBegin(ctx%da, udotvec, INSERT_VALUES, udloc, ierr))
      PetscCall(DMGlobalToLocalEnd(ctx%da, udotvec, INSERT_VALUES, udloc, ierr))
      PetscCall(DMDAVecGetArrayReadF90(ctx%da, udloc, ud, ierr))
      PetscCall(reduced_assemble(ctx%red, u, ud, a, ierr))
      PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, udloc, ud, ierr))
      PetscCall(DMRestoreLocalVector(ctx%da, udloc, ierr))
      PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
      PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
      PetscCall(MatAssemblyBegin(jmat, MAT_FINAL_ASSEMBLY, ierr))
      PetscCall(MatAssemblyEnd(jmat, MAT_FINAL_ASSEMBLY, ierr))
      return
    end if
    ctx%asm%jbuf%k = 0.0_rp
    ctx%asm%jbuf%c = 0.0_rp
    sums = 0.0_rp
    do ja = first_anchor_row(ctx%lat), ctx%lat%ye
      call jac_buffer_row(ctx%asm%jbuf, ctx%lat, u, ja, ctx%model%clamp, ctx%model%gauss_newton)
      if (ja >= ctx%lat%ys) then
        PetscCall(insert_row(ctx, pmat, ja, a, ierr))
        ! the round-off floor of F from this assembly, as the reduced path
        ! takes it from S (module newton_control)
        do i = 0, ctx%lat%nx - 1
          if (ctx%model%fixed(i, ja)) cycle
          do q = 1, 3
            kd(q) = ctx%asm%jbuf%k(q, q, 0, 0, i, slot_of(ja))
          end do
          call floor_node_add(kd, ctx%lat%mass(i, ja), u(0:2, i, ja), a, sums)
        end do
      end if
      ctx%asm%jbuf%k(:, :, :, :, :, slot_of(ja)) = 0.0_rp
      ctx%asm%jbuf%c(:, :, :, :, :, slot_of(ja)) = 0.0_rp
    end do
    PetscCall(DMDAVecRestoreArrayReadF90(ctx%da, uloc, u, ierr))
    PetscCall(DMRestoreLocalVector(ctx%da, uloc, ierr))
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

  !> Insert the complete block rows of node row j.
  subroutine insert_row(ctx, pmat, j, a, ierr)
    type(app_ctx), intent(inout) :: ctx
    type(tMat) :: pmat
    integer, intent(in) :: j
    real(rp), intent(in) :: a
    PetscErrorCode, intent(out) :: ierr
    integer :: i, di, dj, w, nc, s, q
    PetscInt :: row(1), ncol
    real(rp) :: minv

    w = ctx%asm%jbuf%w
    s = slot_of(j)
    ierr = 0
    do i = 0, ctx%lat%nx - 1
      minv = 1.0_rp / ctx%lat%mass(i, j)
      nc = 0
      do dj = -w, w
        if (j + dj < 0 .or. j + dj >= ctx%lat%ny) cycle
        do di = -w, w
          if (i + di < 0 .or. i + di >= ctx%lat%nx) cycle
          nc = nc + 1
          ctx%asm%cols(nc) = (i + di) + (j + dj - ctx%lat%gys) * ctx%lat%nx
          ctx%asm%vals(:, :, nc) = 0.0_rp
          if (ctx%model%fixed(i, j)) then
            if (di == 0 .and. dj == 0) then
              do q = 1, 6
                ctx%asm%vals(q, q, nc) = a
              end do
            end if
            cycle
          end if
          ctx%asm%vals(4:6, 1:3, nc) = ctx%asm%jbuf%k(:, :, di, dj, i, s) * minv
          ctx%asm%vals(4:6, 4:6, nc) = ctx%asm%jbuf%c(:, :, di, dj, i, s) * minv
          if (di == 0 .and. dj == 0) then
            do q = 1, 3
              ctx%asm%vals(q, q, nc) = a
              ctx%asm%vals(q, q + 3, nc) = -1.0_rp
              ctx%asm%vals(q + 3, q + 3, nc) = ctx%asm%vals(q + 3, q + 3, nc) + a
            end do
          end if
        end do
      end do
      row(1) = i + (j - ctx%lat%gys) * ctx%lat%nx
      ncol = nc
      PetscCall(set_block_row(pmat, row, ncol, ctx%asm%cols, ctx%asm%vals, 36 * nc, ierr))
    end do
  end subroutine insert_row

  ! ------------------------------------------- the model's records (owner)

  !> The model's work arrays for the strip of lat (rows ys..ye, ghosts
  !> gys..gye), no node constrained yet, and the model's flags: gravity
  !> [length/time^2] (zero without), clamp (indefinite spring compression
  !> terms dropped from the preconditioner), gauss_newton (Gauss-Newton
  !> energy-bending blocks).
  subroutine model_state_init(m, lat, gravity, clamp, gauss_newton)
    type(model_state_t), intent(inout) :: m
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: gravity(3)
    logical, intent(in) :: clamp, gauss_newton
    allocate(m%f(3, 0:lat%nx - 1, lat%gys:lat%gye))
    allocate(m%fixed(0:lat%nx - 1, lat%ys:lat%ye))
    m%gravity = gravity
    m%fixed = .false.
    m%clamp = clamp
    m%gauss_newton = gauss_newton
  end subroutine model_state_init

  !> A time window's constraint state (enter_window): the nodes of cs (the
  !> rank's own) constrained, the others free; moving: a constrained node
  !> moves in this window (the constraint power is then integrated).
  subroutine model_enter_window(m, cs, moving)
    type(model_state_t), intent(inout) :: m
    type(constraint_set_t), intent(in) :: cs
    logical, intent(in) :: moving
    integer :: k
    m%fixed = .false.
    if (cs%active) then
      do k = 1, cs%n
        m%fixed(cs%node(1, k), cs%node(2, k)) = .true.
      end do
    end if
    m%moving_constraints = moving
  end subroutine model_enter_window

  !> The internal forces of the ghosted state u (the strip of lat, whose
  !> element parameters are used) into the model's work array m%f [force]
  !> (the monitor's constraint power, identification's dF/dp); nbad, bad:
  !> the singular elements met (module forces' internal_forces).
  subroutine model_internal_forces(m, lat, u, nbad, bad)
    type(model_state_t), intent(inout) :: m
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    integer, intent(out) :: nbad, bad(2)
    call internal_forces(lat, u, m%f, nbad, bad)
  end subroutine model_internal_forces

  !> The model's work arrays.
  subroutine model_state_free(m)
    type(model_state_t), intent(inout) :: m
    if (allocated(m%f)) deallocate(m%f)
    if (allocated(m%fixed)) deallocate(m%fixed)
  end subroutine model_state_free

  !> The assembled 6-dof Jacobian on da with the DMDA's exact box-stencil
  !> preallocation, its rolling buffer of element blocks and one block
  !> row's work arrays (w: the halo width). -nuno_jacobian full only.
  !> Collective.
  subroutine assembly_create(a, da, lat, w, ierr)
    type(assembly_t), intent(inout) :: a
    type(tDM), intent(in) :: da
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: w
    PetscErrorCode, intent(out) :: ierr
    integer :: nc
    PetscCall(DMCreateMatrix(da, a%p, ierr))
    PetscCall(MatSetOption(a%p, MAT_ROW_ORIENTED, PETSC_FALSE, ierr))
    call jac_buffer_init(a%jbuf, lat)
    nc = (2 * w + 1)**2
    allocate(a%vals(6, 6, nc), a%cols(nc))
  end subroutine assembly_create

  !> The assembled 6-dof Jacobian and its buffers (-nuno_jacobian full only:
  !> the reduced solve creates none). Collective.
  subroutine assembly_free(a, ierr)
    type(assembly_t), intent(inout) :: a
    PetscErrorCode, intent(out) :: ierr
    PetscCall(MatDestroy(a%p, ierr))
    if (allocated(a%vals)) deallocate(a%vals)
    if (allocated(a%cols)) deallocate(a%cols)
  end subroutine assembly_free

end module cloth_model
