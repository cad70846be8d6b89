! SPDX-License-Identifier: BSD-2-Clause
!> The storage of S in a PETSc matrix for the reduced solve (module
!> reduced) when the inner preconditioner is not nuno's multigrid (whose
!> S by stencil offset is module reduced_mg's): BAIJ or AIJ from the DMDA,
!> an AIJ S filled by writing its CSR value arrays directly (module
!> reduced_assembly's assemble_csr) when its structure is the stencil,
!> else block row by block row from the element buffer. Its record
!> (s_store_t) has private components: only this module writes it.
module reduced_storage
#include "petsc/finclude/petscksp.h"
#include "petsc/finclude/petscdmda.h"
  use petscksp
  use petscdmda
  use mpi
  use kinds, only: rp
  use lattice, only: lattice_t
  use forces, only: jac_buffer_t, jac_buffer_init, jac_buffer_row, slot_of, first_anchor_row
  use reduced_blocks, only: reduced_row_blocks, buffer_row_apply, csr_fits_block_row
  use reduced_assembly, only: assemble_csr
  use node_blocks, only: node_blocks_t
  implicit none
  private
  public :: s_store_t, store_init, store_matrix, store_assemble, check_direct, set_block_row, store_use_buffer, store_direct

  !> The element buffer and one block row's work.
  type :: s_store_t
    private
    type(lattice_t), pointer :: lat => null()
    type(jac_buffer_t) :: jbuf
    real(rp), allocatable :: vals(:, :, :) !< (3, 3, ncol) one block row
    integer, allocatable :: cols(:)        !< (ncol)
    ! An AIJ S is filled by writing its value arrays directly (its structure,
    ! the stencil, never changes; checked once by check_direct).
    logical :: direct = .false.
    logical, allocatable :: owned(:)       !< (ncol) column node owned by this rank
    integer, allocatable :: lcol(:)        !< (ncol) its local node index
  end type s_store_t

  !> The parts of an assembled AIJ S as plain arrays: diagonal part (ia, ja,
  !> av) and off-diagonal part (ib, jb, bv; empty on one rank), 1-based
  !> pointers into PETSc's own arrays (no copies).
  type :: aij_view_t
    private
    type(tMat) :: ad, ao
    logical :: parallel = .false.
    PetscInt :: na = 0, nb = 0
    PetscInt, pointer :: ia(:) => null(), ja(:) => null(), ib(:) => null(), jb(:) => null()
    PetscScalar, pointer :: av(:) => null(), bv(:) => null()
  end type aij_view_t

contains

  subroutine store_init(st, lat)
    type(s_store_t), intent(inout) :: st
    type(lattice_t), intent(in), target :: lat
    st%lat => lat
    call jac_buffer_init(st%jbuf, lat)
    allocate(st%vals(3, 3, (2 * lat%halo + 1)**2), st%cols((2 * lat%halo + 1)**2))
    allocate(st%owned((2 * lat%halo + 1)**2), st%lcol((2 * lat%halo + 1)**2))
  end subroutine store_init

  !> S assembled in a PETSc matrix: BAIJ (3 x 3 blocks) for the point-wise
  !> and block-local preconditioners, whose kernels are blocked; AIJ (with
  !> block size 3) for the algebraic multigrids, which need it.
  !> -reduced_dm_mat_type wins.
  subroutine store_matrix(da3, pctype, symmetric, s, ierr)
    type(tDM), intent(inout) :: da3
    character(len=*), intent(in) :: pctype      !< the inner preconditioner's type
    logical, intent(in) :: symmetric            !< S is symmetric
    type(tMat), intent(out) :: s
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: mattype
    MPI_Comm :: comm
    PetscCall(PetscObjectGetComm(da3, comm, ierr))
    select case (trim(pctype))
  case (PCJACOBI, PCPBJACOBI, PCBJACOBI, PCASM, PCSOR, PCILU, PCICC, PCNONE)
      PetscCall(DMSetMatType(da3, MATBAIJ, ierr))
    case default
      PetscCall(DMSetMatType(da3, MATAIJ, ierr))
    end select
    PetscCall(DMSetFromOptions(da3, ierr))
    PetscCall(DMSetUp(da3, ierr))
    PetscCall(DMCreateMatrix(da3, s, ierr))
    PetscCall(MatSetOption(s, MAT_ROW_ORIENTED, PETSC_FALSE, ierr))
    PetscCall(MatSetOption(s, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE, ierr))
    PetscCall(MatGetType(s, mattype, ierr))
    if (index(mattype, 'sbaij') > 0) then
      ! Symmetric storage keeps the upper triangle: S must be symmetric.
      if (.not. symmetric) then
        ierr = PETSC_ERR_ARG_INCOMP
        SETERRQ(comm, ierr, 'nuno: -reduced_dm_mat_type sbaij needs a symmetric S (no moving dampers, no paper bending, eta_b = 0)')
      end if
      PetscCall(MatSetOption(s, MAT_IGNORE_LOWER_TRIANGULAR, PETSC_TRUE, ierr))
    end if
    if (symmetric) then
      PetscCall(MatSetOption(s, MAT_SYMMETRIC, PETSC_TRUE, ierr))
      PetscCall(MatSetOption(s, MAT_SYMMETRY_ETERNAL, PETSC_TRUE, ierr))
    end if
  end subroutine store_matrix

  !> Fill S block row by block row from the element buffer even where its
  !> values could be written directly (a test compares the two).
  subroutine store_use_buffer(st)
    type(s_store_t), intent(inout) :: st
    st%direct = .false.
  end subroutine store_use_buffer

  !> An AIJ S is written straight into its value arrays (check_direct).
  pure logical function store_direct(st)
    type(s_store_t), intent(in) :: st
    store_direct = st%direct
  end function store_direct

  !> S at the ghosted state u and shift a into the matrix s (not yet
  !> assembled), with the products gpred of wpred and the diagonal kd on the
  !> way (see module reduced's reduced_assemble). Collective for an AIJ S
  !> written directly.
  subroutine store_assemble(st, s, nodal, u, fixedg, a, damping, clamp, gauss_newton, wpred, lb, gpred, kd, ierr)
    type(s_store_t), intent(inout) :: st
    type(tMat) :: s
    type(node_blocks_t), intent(in) :: nodal
    real(rp), intent(in) :: u(0:, 0:, st%lat%gys:)
    logical, intent(in) :: fixedg(0:, st%lat%gys:)
    real(rp), intent(in) :: a
    logical, intent(in) :: damping, clamp, gauss_newton
    real(rp), intent(in) :: wpred(0:, 0:, st%lat%gys:)
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:)
    real(rp), intent(inout) :: gpred(:, 0:, st%lat%ys:)
    real(rp), intent(inout) :: kd(:, 0:, st%lat%ys:)
    PetscErrorCode, intent(out) :: ierr
    integer :: ja, i, nc, q
    PetscInt :: row(1), ncol
    type(aij_view_t) :: view
    ierr = 0
    if (st%direct) then
      ! AIJ: element blocks straight into the CSR values (module reduced_assembly).
      PetscCall(aij_open(s, view, ierr))
      call assemble_csr(st%lat, nodal, u, fixedg, a, damping, clamp, gauss_newton, wpred, &
                        lb, gpred, kd, view%ia, view%av, view%ib, view%bv)
      PetscCall(aij_close(view, ierr))
    else
      st%jbuf%k = 0.0_rp
      st%jbuf%c = 0.0_rp
      do ja = first_anchor_row(st%lat), st%lat%ye
        call jac_buffer_row(st%jbuf, st%lat, nodal, u, ja, clamp, gauss_newton)
        if (ja >= st%lat%ys) then
          call buffer_row_apply(st%jbuf, st%lat, wpred, ja, damping, gpred(:, :, ja))
          do i = 0, st%lat%nx - 1
            do q = 1, 3
              kd(q, i, ja) = st%jbuf%k(q, q, 0, 0, i, slot_of(ja))
            end do
            call reduced_row_blocks(st%jbuf, st%lat, fixedg, i, ja, a, damping, st%vals, st%cols, nc)
            row(1) = i + (ja - st%lat%gys) * st%lat%nx
            ncol = nc
            PetscCall(set_block_row(s, row, ncol, st%cols, st%vals, 9 * nc, ierr))
          end do
        end if
        st%jbuf%k(:, :, :, :, :, slot_of(ja)) = 0.0_rp
        st%jbuf%c(:, :, :, :, :, slot_of(ja)) = 0.0_rp
      end do
    end if
  end subroutine store_assemble

  !> Column ownership of the block row in cols(1:nc): owned(n) when its
  !> node lies in this rank's rows, lcol(n) its local node index there.
  subroutine mark_owned(st, nc)
    type(s_store_t), intent(inout) :: st
    integer, intent(in) :: nc
    integer :: n, jn
    do n = 1, nc
      jn = st%cols(n) / st%lat%nx + st%lat%gys
      st%owned(n) = jn >= st%lat%ys .and. jn <= st%lat%ye
      st%lcol(n) = st%cols(n) - (st%lat%ys - st%lat%gys) * st%lat%nx
    end do
  end subroutine mark_owned

  !> Open the value and row arrays of an AIJ S (see aij_view_t).
  subroutine aij_open(s, view, ierr)
    type(tMat), intent(in) :: s
    type(aij_view_t), intent(inout) :: view
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: mattype
    PetscInt :: ic(1)
    PetscOffset :: iic
    PetscBool :: done
    PetscInt, parameter :: shift = 0
    PetscInt, pointer, save :: none_i(:) => null()
    PetscScalar, pointer, save :: none_s(:) => null()

    if (.not. associated(none_i)) allocate(none_i(0), none_s(0))
    PetscCall(MatGetType(s, mattype, ierr))
    view%parallel = mattype == MATMPIAIJ
    if (view%parallel) then
      PetscCall(MatMPIAIJGetSeqAIJ(s, view%ad, view%ao, ic, iic, ierr))
    else
      view%ad = s
    end if
    PetscCall(MatGetRowIJF90(view%ad, shift, PETSC_FALSE, PETSC_FALSE, view%na, view%ia, view%ja, done, ierr))
    PetscCall(MatSeqAIJGetArrayF90(view%ad, view%av, ierr))
    if (view%parallel) then
      PetscCall(MatGetRowIJF90(view%ao, shift, PETSC_FALSE, PETSC_FALSE, view%nb, view%ib, view%jb, done, ierr))
      PetscCall(MatSeqAIJGetArrayF90(view%ao, view%bv, ierr))
    else
      view%ib => none_i
      view%jb => none_i
      view%bv => none_s
    end if
  end subroutine aij_open

  !> Give the arrays back and assemble S (which also drops its cached
  !> diagonal inverses, so that SOR sees the new values).
  subroutine aij_close(view, ierr)
    type(aij_view_t), intent(inout) :: view
    PetscErrorCode, intent(out) :: ierr
    PetscBool :: done
    PetscInt, parameter :: shift = 0
    PetscCall(MatSeqAIJRestoreArrayF90(view%ad, view%av, ierr))
    PetscCall(MatRestoreRowIJF90(view%ad, shift, PETSC_FALSE, PETSC_FALSE, view%na, view%ia, view%ja, done, ierr))
    if (view%parallel) then
      PetscCall(MatSeqAIJRestoreArrayF90(view%ao, view%bv, ierr))
      PetscCall(MatRestoreRowIJF90(view%ao, shift, PETSC_FALSE, PETSC_FALSE, view%nb, view%ib, view%jb, done, ierr))
    end if
  end subroutine aij_close

  !> Write S's values directly when S is AIJ and its structure (from the
  !> DMDA's preallocation) is the stencil of reduced_row_blocks, row by row
  !> and in the same order, on every rank; otherwise keep MatSetValues.
  !> Collective, once.
  subroutine check_direct(st, s, da3, fixedg, damping, ierr)
    type(s_store_t), intent(inout) :: st
    type(tMat), intent(in) :: s
    type(tDM), intent(in) :: da3
    logical, intent(in) :: fixedg(0:, st%lat%gys:)   !< (0:nx-1, gys:gye) constrained nodes
    logical, intent(in) :: damping                   !< some element has a damper
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: mattype
    type(aij_view_t) :: view
    integer :: i, j, nc, mpierr
    logical :: ok, all_ok
    MPI_Comm :: comm

    st%direct = .false.
    PetscCall(MatGetType(s, mattype, ierr))
    ok = mattype == MATSEQAIJ .or. mattype == MATMPIAIJ
    if (ok) then
      PetscCall(aij_open(s, view, ierr))
      st%jbuf%k = 0.0_rp
      st%jbuf%c = 0.0_rp
      do j = st%lat%ys, st%lat%ye
        do i = 0, st%lat%nx - 1
          call reduced_row_blocks(st%jbuf, st%lat, fixedg, i, j, 1.0_rp, damping, st%vals, st%cols, nc)
          call mark_owned(st, nc)
          ok = ok .and. csr_fits_block_row(nc, st%owned, st%lcol, 3 * (i + (j - st%lat%ys) * st%lat%nx), &
                                           view%ia, view%ja, view%ib, view%jb)
        end do
      end do
      PetscCall(aij_close(view, ierr))
    end if
    PetscCall(PetscObjectGetComm(da3, comm, ierr))
    call MPI_Allreduce(ok, all_ok, 1, MPI_LOGICAL, MPI_LAND, comm, mpierr)
    st%direct = all_ok
  end subroutine check_direct

  !> One block row into the matrix: vals as the flat array PETSc takes.
  !> (Also used by the 6-dof path in module timestepping, through module reduced.)
  subroutine set_block_row(mat, row, ncol, cols, vals, n, ierr)
    type(tMat) :: mat
    PetscInt, intent(in) :: row(1), ncol
    PetscInt, intent(in) :: cols(ncol)
    integer, intent(in) :: n
    PetscScalar, intent(in) :: vals(n)
    PetscErrorCode, intent(out) :: ierr
    PetscInt, parameter :: one = 1
    call MatSetValuesBlockedLocal(mat, one, row, ncol, cols, vals, INSERT_VALUES, ierr)
  end subroutine set_block_row

end module reduced_storage
