! SPDX-License-Identifier: BSD-2-Clause
!> The process model's state (the records app_ctx%model and app_ctx%asm;
!> the callbacks are module cloth_model's): the force work array and the
!> window's constrained nodes, the singular element the last residual met,
!> and the assembled 6-dof Jacobian with its work buffers (-nuno_jacobian
!> full). This module is the records' only writer: the residual on plain
!> arrays (model_residual), the 6-dof assembly (model_assemble_full), the
!> window's constraint state; and it hands the window's constrained nodes
!> to the process models' hooks (module process_models' loops), the
!> reduced solve's elimination and identification's dF/dp, so that no
!> other module holds the mask.
module model_state
#include "petsc/finclude/petscdm.h"
  use petscdm
  use kinds, only: rp
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t, constraint_target, constraints_active, constraint_count, constraint_node
  use forces, only: internal_forces, jac_buffer_t, jac_buffer_init, jac_buffer_row, slot_of, first_anchor_row
  use newton_control, only: floor_node_add
  use reduced_storage, only: set_block_row
  use reduced, only: reduced_t, reduced_set_fixed
  use node_blocks, only: node_blocks_t
  use process_models, only: pm_list_t, pm_list_on, pm_list_forces, pm_list_jacobian, pm_list_step_limit, pm_list_correct, pm_list_accept, &
                            pm_list_limit_nodes, pm_list_accepted, pm_list_unresolved, pm_list_start_limit, pm_list_start
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  implicit none
  private
  public :: model_state_t, model_state_init, model_state_free, model_enter_window, model_residual, model_constraint_power, &
            model_force_rows
  public :: model_gravity, model_moving, model_singular
  public :: model_fixed_to_reduced, model_pm_jacobian, model_pm_step_limit, model_pm_correct, model_pm_accept, model_pm_accepted, &
            model_pm_unresolved, model_pm_start_limit, model_pm_limit_nodes
  public :: model_pm_start
  public :: assembly_t, assembly_create, assembly_free, assembly_matrix, model_assemble_full

  !> The model's state within a time window and its work arrays.
  type :: model_state_t
    private
    real(rp), allocatable :: f(:, :, :)         !< (3, 0:nx-1, gys:gye) force work array [force]
    logical, allocatable :: fixed(:, :)         !< (0:nx-1, ys:ye) constrained in the current window
    real(rp) :: gravity(3) = 0                  !< [length/time^2]
    logical :: clamp = .false.                  !< drop indefinite spring compression terms in P
    logical :: gauss_newton = .false.           !< Gauss-Newton energy-bending blocks in P
    logical :: moving_constraints = .false.     !< a constrained node moves in this window
    !> the singular element seen by the last residual evaluation: how many,
    !> one of them (link end nodes) and the time
    integer :: nbad = 0, bad(2) = -1
    real(rp) :: t_bad = 0
  end type model_state_t

  !> The assembled 6-dof Jacobian and its work buffers (-nuno_jacobian full).
  type :: assembly_t
    private
    type(jac_buffer_t) :: jbuf                  !< rolling rows of element blocks
    type(tMat) :: p                             !< assembled 6-dof Jacobian
    real(rp), allocatable :: vals(:, :, :)      !< (6, 6, ncol) one block row of the Jacobian
    PetscInt, allocatable :: cols(:)            !< (ncol) its local block columns
  end type assembly_t

contains

  ! ------------------------------------------------------ the model's state

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

  !> The model's work arrays.
  subroutine model_state_free(m)
    type(model_state_t), intent(inout) :: m
    if (allocated(m%f)) deallocate(m%f)
    if (allocated(m%fixed)) deallocate(m%fixed)
  end subroutine model_state_free

  !> A time window's constraint state (enter_window): the nodes of cs (the
  !> rank's own) constrained, the others free; moving: a constrained node
  !> moves in this window (the constraint power is then integrated).
  subroutine model_enter_window(m, cs, moving)
    type(model_state_t), intent(inout) :: m
    type(constraint_set_t), intent(in) :: cs
    logical, intent(in) :: moving
    integer :: k, i, j
    m%fixed = .false.
    if (constraints_active(cs)) then
      do k = 1, constraint_count(cs)
        call constraint_node(cs, k, i, j)
        m%fixed(i, j) = .true.
      end do
    end if
    m%moving_constraints = moving
  end subroutine model_enter_window

  !> The residual F(t, U, Udot) on plain arrays (module cloth_model's
  !> header): u the ghosted state (0:5, 0:nx-1, gys:gye), ud its time
  !> derivative and fv the residual on the owned rows. A singular element
  !> (zero-length link, bending triple at pi) makes the residual NaN, so
  !> that SNES fails the step collectively (model_singular says why). The
  !> process models' forces (pms, module process_models) are added to f;
  !> a state outside a model's domain is the list's flag
  !> (pm_list_infeasible: module process_solver makes it PETSc's domain
  !> error), agreed over comm. Collective when pms has models.
  subroutine model_residual(m, lat, cs, pms, comm, t, u, ud, fv)
    type(model_state_t), intent(inout) :: m
    type(lattice_t), intent(in) :: lat
    type(constraint_set_t), intent(in) :: cs
    type(pm_list_t), intent(inout) :: pms
    integer, intent(in) :: comm
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(in) :: ud(0:5, 0:lat%nx - 1, lat%ys:lat%ye)
    real(rp), intent(out) :: fv(0:5, 0:lat%nx - 1, lat%ys:lat%ye)
    integer :: i, j, k, nbad, bad(2)
    real(rp) :: xb(3), vb(3)

    call internal_forces(lat, u, m%f, nbad, bad)
    if (pm_list_on(pms)) call pm_list_forces(pms, lat, m%fixed, t, u, m%f(:, :, lat%ys:lat%ye), comm)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        fv(0:2, i, j) = ud(0:2, i, j) - u(3:5, i, j)
        fv(3:5, i, j) = ud(3:5, i, j) - m%f(:, i, j) / lat%mass(i, j) - m%gravity
      end do
    end do
    if (constraints_active(cs)) then
      do k = 1, constraint_count(cs)
        call constraint_target(cs, k, t, xb, vb)
        call constraint_node(cs, k, i, j)
        fv(0:2, i, j) = ud(0:2, i, j) - vb
        fv(3:5, i, j) = ud(3:5, i, j)
      end do
    end if
    if (nbad > 0) then
      m%nbad = nbad
      m%bad = bad
      m%t_bad = t
      fv(0, 0, lat%ys) = ieee_value(1.0_rp, ieee_quiet_nan)
    end if
  end subroutine model_residual

  !> This rank's power of the constraint reactions at the ghosted state u
  !> at time t, -sum over its constrained nodes of (f_internal + m g) .
  !> vbar [energy/time] (the monitor's constraint work; the internal forces
  !> into the work array).
  real(rp) function model_constraint_power(m, lat, cs, u, t) result(p)
    type(model_state_t), intent(inout) :: m
    type(lattice_t), intent(in) :: lat
    type(constraint_set_t), intent(in) :: cs
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(in) :: t
    real(rp) :: xb(3), vb(3)
    integer :: k, i, j, nbad, bad(2)
    p = 0.0_rp
    call internal_forces(lat, u, m%f, nbad, bad)
    do k = 1, constraint_count(cs)
      call constraint_target(cs, k, t, xb, vb)
      call constraint_node(cs, k, i, j)
      p = p - dot_product(m%f(:, i, j) + lat%mass(i, j) * m%gravity, vb)
    end do
  end function model_constraint_power

  !> The v-rows of a parameter's column of dF/dp (identification): the
  !> internal forces of the ghosted state u with lat's element parameters
  !> (one parameter's terms), sgn f/m on the free nodes into col's rows
  !> 3:5 (col: the column, (0:5, 0:nx-1, ys:ye); the x-rows and the
  !> constrained nodes' rows are left as they are); nbad, bad: the singular
  !> elements met.
  subroutine model_force_rows(m, lat, u, sgn, col, nbad, bad)
    type(model_state_t), intent(inout) :: m
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(in) :: sgn
    real(rp), intent(inout) :: col(0:5, 0:lat%nx - 1, lat%ys:lat%ye)
    integer, intent(out) :: nbad, bad(2)
    integer :: i, j
    call internal_forces(lat, u, m%f, nbad, bad)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (m%fixed(i, j)) cycle
        col(3:5, i, j) = sgn * m%f(:, i, j) / lat%mass(i, j)
      end do
    end do
  end subroutine model_force_rows

  !> Gravity [length/time^2] (zero without).
  pure function model_gravity(m) result(g)
    type(model_state_t), intent(in) :: m
    real(rp) :: g(3)
    g = m%gravity
  end function model_gravity

  !> A constrained node moves in the current window.
  pure logical function model_moving(m)
    type(model_state_t), intent(in) :: m
    model_moving = m%moving_constraints
  end function model_moving

  !> The singular elements the last residual evaluation met on this rank
  !> (nbad; 0: none), one of them (bad: its link's end node) and the time.
  pure subroutine model_singular(m, nbad, bad, t_bad)
    type(model_state_t), intent(in) :: m
    integer, intent(out) :: nbad, bad(2)
    real(rp), intent(out) :: t_bad
    nbad = m%nbad
    bad = m%bad
    t_bad = m%t_bad
  end subroutine model_singular

  ! ---------------- the window's constrained nodes, to the kernels that skip them

  !> The reduced solve's constrained nodes are the window's (enter_window).
  !> Collective.
  subroutine model_fixed_to_reduced(m, red, ierr)
    type(model_state_t), intent(in) :: m
    type(reduced_t), intent(inout) :: red
    PetscErrorCode, intent(out) :: ierr
    PetscCall(reduced_set_fixed(red, m%fixed, ierr))
  end subroutine model_fixed_to_reduced

  !> The process models' blocks at the ghosted state u at time t (module
  !> process_models' pm_list_jacobian, which the assemblies then add);
  !> two_models: more than one model gave pair blocks. Collective over comm.
  subroutine model_pm_jacobian(m, pms, lat, t, u, comm, two_models)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    logical, intent(out) :: two_models
    call pm_list_jacobian(pms, lat, m%fixed, t, u, comm, two_models)
  end subroutine model_pm_jacobian

  !> The process models' second-order correction of the Newton update dx
  !> at x (module process_models' pm_list_correct). Collective.
  subroutine model_pm_correct(m, pms, lat, t0, t1, x, dx, comm, changed)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    call pm_list_correct(pms, lat, m%fixed, t0, t1, x, dx, comm, changed)
  end subroutine model_pm_correct

  !> The process models' per-node limit of the update dx from x (module
  !> process_models' pm_list_limit_nodes). Collective.
  subroutine model_pm_limit_nodes(m, pms, lat, t0, t1, x, dx, comm, changed)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    call pm_list_limit_nodes(pms, lat, m%fixed, t0, t1, x, dx, comm, changed)
  end subroutine model_pm_limit_nodes

  !> The fraction alpha of the Newton update x -> x + dx (from x0 at t0 to
  !> the step's end t1) that the process models allow, and infeasible:
  !> none (module process_models' pm_list_step_limit). Collective.
  subroutine model_pm_step_limit(m, pms, lat, t0, t1, x0, x, dx, comm, alpha, infeasible)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    logical, intent(out) :: infeasible
    call pm_list_step_limit(pms, lat, m%fixed, t0, t1, x0, x, dx, comm, alpha, infeasible)
  end subroutine model_pm_step_limit

  !> The fraction alpha of the move from x0 (the step's start at t0) to a
  !> Newton start x0 + dx for the step to t1 that the process models
  !> allow, and infeasible: none (module process_models'
  !> pm_list_start_limit). Collective.
  subroutine model_pm_start_limit(m, pms, lat, t0, t1, x0, dx, comm, alpha, infeasible)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    logical, intent(out) :: infeasible
    call pm_list_start_limit(pms, lat, m%fixed, t0, t1, x0, dx, comm, alpha, infeasible)
  end subroutine model_pm_start_limit

  !> Newton's start x (owned rows) of a step from x0 at t0 to t1, moved
  !> into the process models' domains (module process_models'
  !> pm_list_start); moved: the nodes moved on this rank.
  subroutine model_pm_start(m, pms, lat, t0, t1, x0, x, moved)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: x(0:, 0:, lat%ys:)
    integer, intent(out) :: moved
    call pm_list_start(pms, lat, m%fixed, t0, t1, x0, x, moved)
  end subroutine model_pm_start

  !> A step's end state u at t accepted by every process model (module
  !> process_models' pm_list_accept). Collective.
  subroutine model_pm_accept(m, pms, lat, t, u, comm, ok)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    logical, intent(out) :: ok
    call pm_list_accept(pms, lat, m%fixed, t, u, comm, ok)
  end subroutine model_pm_accept

  !> The free nodes whose process-model forces a step of dt does not
  !> resolve at u, t (module process_models' pm_list_unresolved).
  subroutine model_pm_unresolved(m, pms, lat, t, u, dt, mask)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(in) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t, dt
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    logical, intent(out) :: mask(0:, lat%ys:)
    call pm_list_unresolved(pms, lat, m%fixed, t, u, dt, mask)
  end subroutine model_pm_unresolved

  !> An accepted state u at t: the process models' accepted hooks (module
  !> process_models' pm_list_accepted). Collective.
  subroutine model_pm_accepted(m, pms, lat, t, u, comm, ierr, errmsg)
    type(model_state_t), intent(in) :: m
    type(pm_list_t), intent(inout) :: pms
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    call pm_list_accepted(pms, lat, m%fixed, t, u, comm, ierr, errmsg)
  end subroutine model_pm_accepted

  ! ------------------------------------------ the assembled 6-dof Jacobian

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

  !> The assembled 6-dof Jacobian (the TS's IJacobian matrix).
  function assembly_matrix(a) result(p)
    type(assembly_t), intent(in) :: a
    type(tMat) :: p
    p = a%p
  end function assembly_matrix

  !> dF/dU + shift dF/dUdot (v-rows: -K/m and shift I - C/m) at the ghosted
  !> state u into pmat (a%p), row by row from the rolling buffer of element
  !> blocks: one MatSetValuesBlockedLocal per node, INSERT_VALUES over the
  !> whole preallocated stencil (so no MatZeroEntries is needed); sums:
  !> this rank's sums of the round-off floor (module newton_control's
  !> floor_node_add), as the reduced path takes it from S. The caller
  !> assembles pmat.
  subroutine model_assemble_full(m, a, lat, nodal, u, shift, pmat, sums, ierr)
    type(model_state_t), intent(in) :: m
    type(assembly_t), intent(inout) :: a
    type(lattice_t), intent(in) :: lat
    type(node_blocks_t), intent(in) :: nodal     !< the process models' node blocks (module process_models)
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(in) :: shift
    type(tMat) :: pmat
    real(rp), intent(out) :: sums(2)
    PetscErrorCode, intent(out) :: ierr
    integer :: ja, i, q
    real(rp) :: kd(3)

    ierr = 0
    a%jbuf%k = 0.0_rp
    a%jbuf%c = 0.0_rp
    sums = 0.0_rp
    do ja = first_anchor_row(lat), lat%ye
      call jac_buffer_row(a%jbuf, lat, nodal, u, ja, m%clamp, m%gauss_newton)
      if (ja >= lat%ys) then
        PetscCall(insert_row(m, a, lat, pmat, ja, shift, ierr))
        ! the round-off floor of F from this assembly
        do i = 0, lat%nx - 1
          if (m%fixed(i, ja)) cycle
          do q = 1, 3
            kd(q) = a%jbuf%k(q, q, 0, 0, i, slot_of(ja))
          end do
          call floor_node_add(kd, lat%mass(i, ja), u(0:2, i, ja), shift, sums)
        end do
      end if
      a%jbuf%k(:, :, :, :, :, slot_of(ja)) = 0.0_rp
      a%jbuf%c(:, :, :, :, :, slot_of(ja)) = 0.0_rp
    end do
  end subroutine model_assemble_full

  !> Insert the complete block rows of node row j.
  subroutine insert_row(m, a, lat, pmat, j, shift, ierr)
    type(model_state_t), intent(in) :: m
    type(assembly_t), intent(inout) :: a
    type(lattice_t), intent(in) :: lat
    type(tMat) :: pmat
    integer, intent(in) :: j
    real(rp), intent(in) :: shift
    PetscErrorCode, intent(out) :: ierr
    integer :: i, di, dj, w, nc, s, q
    PetscInt :: row(1), ncol
    real(rp) :: minv

    w = a%jbuf%w
    s = slot_of(j)
    ierr = 0
    do i = 0, lat%nx - 1
      minv = 1.0_rp / lat%mass(i, j)
      nc = 0
      do dj = -w, w
        if (j + dj < 0 .or. j + dj >= lat%ny) cycle
        do di = -w, w
          if (i + di < 0 .or. i + di >= lat%nx) cycle
          nc = nc + 1
          a%cols(nc) = (i + di) + (j + dj - lat%gys) * lat%nx
          a%vals(:, :, nc) = 0.0_rp
          if (m%fixed(i, j)) then
            if (di == 0 .and. dj == 0) then
              do q = 1, 6
                a%vals(q, q, nc) = shift
              end do
            end if
            cycle
          end if
          a%vals(4:6, 1:3, nc) = a%jbuf%k(:, :, di, dj, i, s) * minv
          a%vals(4:6, 4:6, nc) = a%jbuf%c(:, :, di, dj, i, s) * minv
          if (di == 0 .and. dj == 0) then
            do q = 1, 3
              a%vals(q, q, nc) = shift
              a%vals(q, q + 3, nc) = -1.0_rp
              a%vals(q + 3, q + 3, nc) = a%vals(q + 3, q + 3, nc) + shift
            end do
          end if
        end do
      end do
      row(1) = i + (j - lat%gys) * lat%nx
      ncol = nc
      PetscCall(set_block_row(pmat, row, ncol, a%cols, a%vals, 36 * nc, ierr))
    end do
  end subroutine insert_row

end module model_state
