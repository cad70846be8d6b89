! SPDX-License-Identifier: BSD-2-Clause
!> The rediscretised coarse levels of nuno's multigrid (issue 46;
!> -nuno_mg_coarse rediscretize): level l is the same cloth on the lattice
!> coarsened 2^(l-1) times (module coarse_lattice), at the finest state
!> injected (every 2^(l-1)-th node), with the same constraints, shift and
!> element model, and the process models' node blocks (contact) lumped
!> onto their nodes and summed with the bilinear weights level by level
!> (as the masses are), assembled by the finest level's assembly (module
!> reduced_assembly's assemble_stencil) straight into the level's operator
!> (module stencil_mg's mg_level_op). Every level then has the finest
!> level's reach and offsets (16 blocks a node with bending, 8 without),
!> and a fourth-order part consistent with the finest one's, which the
!> bilinear Galerkin product is not (docs/performance.md).
!>
!> Parallel: a distributed level's rows are injected on the rank that owns
!> them (coarse row J's fine row 2^(l-1) J is the same rank's), and its
!> ghost rows exchanged with the neighbours; the replicated coarsest level
!> (several ranks) is summed from every rank's rows. Its record has private
!> components: only this module writes it.
module mg_coarse
  use mpi
  use kinds, only: rp
  use lattice, only: lattice_t, lattice_coarsened
  use coarse_lattice, only: mass_factors, restrict_factors, inject_rows
  use node_blocks, only: node_blocks_t, node_blocks_count, node_blocks_lumped, node_blocks_begin, node_blocks_add, &
                         node_blocks_end
  use reduced_assembly, only: assemble_stencil
  use offset_product, only: offset_count
  use mg_kernels, only: stencil_t
  use stencil_mg, only: stencil_mg_t, mg_levels, mg_level_rows, mg_level_op, mg_set_level_fixed, mg_factor_coarsest
  implicit none
  private
  public :: mg_coarse_t, mg_coarse_init, mg_coarse_build, mg_coarse_free

  !> One coarse level's lattice, state and the assembly's work arrays.
  type :: coarse_level_t
    type(lattice_t) :: lat                         !< the cloth on this level's lattice (rows of this rank, ghosts)
    integer :: stride = 1                          !< 2^(l-1): node (i, j) is the finest node (stride i, stride j)
    integer :: j0 = 0, j1 = -1                     !< the rows injected on this rank (their finest rows are its own)
    logical :: replicated = .false.                !< every rank holds every row (and assembles them)
    !> (0:6, 0:nx-1, gys:gye) the state (0:5) and the constraint mark (6: 1 or 0)
    real(rp), allocatable :: u(:, :, :)
    logical, allocatable :: fixed(:, :)            !< (0:nx-1, gys:gye) constrained nodes
    real(rp), allocatable :: w(:, :, :)            !< (0:5, 0:nx-1, gys:gye) zero: no element products wanted
    real(rp), allocatable :: st(:, :, :, :, :)     !< (0:nx-1, 3, 3, offset_count(halo), 0:2 halo-2) the assembly's ring of rows
    real(rp), allocatable :: lb(:, :, :, :, :)     !< (0:nx-1, 3, 3, 4, 0:1) link blocks of two rows
    real(rp), allocatable :: g(:, :, :), kd(:, :, :) !< (3, 0:nx-1, ys:ye) the assembly's products (not used)
    !> (18, 0:nx-1, gys:gye) the process models' node blocks restricted to
    !> this level (kx 1:9, kv 10:18; allocated at the first rebuild with any, then kept)
    real(rp), allocatable :: d(:, :, :)
    type(node_blocks_t) :: nodal                   !< d as this level's node blocks, for its assembly
  end type coarse_level_t

  type :: mg_coarse_t
    private
    integer :: comm = MPI_COMM_NULL, nranks = 1, below = MPI_PROC_NULL, above = MPI_PROC_NULL
    type(coarse_level_t), allocatable :: lev(:)    !< (2:nlev)
    !> (18, 0:nx-1, gys:gye) the finest level's node blocks lumped onto
    !> their nodes, with ghost rows (allocated at the first rebuild with any, then kept)
    real(rp), allocatable :: df(:, :, :)
  end type mg_coarse_t

contains

  !> The coarse lattices of the levels of mg (made by mg_create with
  !> rediscretize) from the finest lattice fine, and their arrays.
  !> Collective only in that every rank calls it.
  subroutine mg_coarse_init(mc, mg, fine, comm)
    type(mg_coarse_t), intent(inout) :: mc
    type(stencil_mg_t), intent(in) :: mg
    type(lattice_t), intent(in) :: fine
    integer, intent(in) :: comm
    real(rp), allocatable :: mxf(:), myf(:), mxc(:), myc(:)
    real(rp) :: scale
    integer :: l, nx, ny, ys, ye, ierr, rank
    logical :: rep
    mc%comm = comm
    call MPI_Comm_rank(comm, rank, ierr)
    call MPI_Comm_size(comm, mc%nranks, ierr)
    mc%below = merge(rank - 1, MPI_PROC_NULL, rank > 0)
    mc%above = merge(rank + 1, MPI_PROC_NULL, rank < mc%nranks - 1)
    if (allocated(mc%lev)) deallocate(mc%lev)
    allocate(mc%lev(2:max(2, mg_levels(mg))))
    call mass_factors(fine, mxf, myf, scale)
    do l = 2, mg_levels(mg)
      call mg_level_rows(mg, l, nx, ny, ys, ye, rep)
      allocate(mxc(0:nx - 1), myc(0:ny - 1))
      call restrict_factors(mxf, mxc)
      call restrict_factors(myf, myc)
      associate (c => mc%lev(l))
        if (l == 2) then
          call lattice_coarsened(fine, c%lat, ys, ye, mxc, myc, scale)
        else
          call lattice_coarsened(mc%lev(l - 1)%lat, c%lat, ys, ye, mxc, myc, scale)
        end if
        c%stride = 2**(l - 1)
        c%replicated = rep
        ! the rows whose finest rows this rank owns
        c%j0 = (fine%ys + c%stride - 1) / c%stride
        c%j1 = fine%ye / c%stride
        call level_arrays(c)
      end associate
      call move_alloc(mxc, mxf)
      call move_alloc(myc, myf)
    end do
  end subroutine mg_coarse_init

  subroutine level_arrays(c)
    type(coarse_level_t), intent(inout) :: c
    integer :: nx, gys, gye, h
    nx = c%lat%nx
    gys = c%lat%gys
    gye = c%lat%gye
    h = c%lat%halo
    allocate(c%u(0:6, 0:nx - 1, gys:gye), c%fixed(0:nx - 1, gys:gye), c%w(0:5, 0:nx - 1, gys:gye))
    allocate(c%st(0:nx - 1, 3, 3, offset_count(h), 0:2 * h - 2), c%lb(0:nx - 1, 3, 3, 4, 0:1))
    allocate(c%g(3, 0:nx - 1, c%lat%ys:c%lat%ye), c%kd(3, 0:nx - 1, c%lat%ys:c%lat%ye))
    c%u = 0.0_rp
    c%w = 0.0_rp
    c%st = 0.0_rp
    c%lb = 0.0_rp
  end subroutine level_arrays

  subroutine mg_coarse_free(mc)
    type(mg_coarse_t), intent(inout) :: mc
    if (allocated(mc%lev)) deallocate(mc%lev)
  end subroutine mg_coarse_free

  !> Every coarse level of mg assembled at the finest state u(0:5,
  !> 0:nx-1, gys:gye) of lattice fine with the constrained nodes fixedg
  !> (0:nx-1, gys:gye), shift a and the element flags (module
  !> reduced_assembly), and with the process models' node blocks nodal
  !> (contact) restricted onto it, then the coarsest level factored.
  !> ierr /= 0: the coarsest matrix is singular. Collective.
  subroutine mg_coarse_build(mc, mg, fine, nodal, u, fixedg, a, damping, clamp, gauss_newton, ierr)
    type(mg_coarse_t), intent(inout) :: mc
    type(stencil_mg_t), intent(inout) :: mg
    type(lattice_t), intent(in) :: fine
    type(node_blocks_t), intent(in) :: nodal       !< the finest level's node blocks (empty: none)
    real(rp), intent(in) :: u(0:, 0:, fine%gys:)
    logical, intent(in) :: fixedg(0:, fine%gys:)
    real(rp), intent(in) :: a
    logical, intent(in) :: damping, clamp, gauss_newton
    integer, intent(out) :: ierr
    type(stencil_t), pointer :: op
    integer :: l
    logical :: blocks
    ierr = 0
    ! node blocks on any rank (the restriction exchanges rows: all or none)
    blocks = node_blocks_count(nodal) > 0
    if (mc%nranks > 1) call MPI_Allreduce(MPI_IN_PLACE, blocks, 1, MPI_LOGICAL, MPI_LOR, mc%comm, ierr)
    if (blocks) call lump_finest(mc, fine, nodal, fixedg)
    do l = 2, mg_levels(mg)
      associate (c => mc%lev(l))
        call inject(mc, c, fine, u, fixedg)
        call level_blocks(mc, l, fine, blocks)
        op => mg_level_op(mg, l)
        call assemble_stencil(c%lat, c%nodal, c%u, c%fixed, a, damping, clamp, gauss_newton, c%w, c%lb, c%g, c%kd, &
                              c%st, op)
        call mg_set_level_fixed(mg, l, c%fixed(:, c%lat%ys:c%lat%ye))
      end associate
    end do
    call mg_factor_coarsest(mg, ierr)
  end subroutine mg_coarse_build

  !> The finest level's node blocks lumped onto their nodes (df), with
  !> the neighbours' rows in the ghost rows. Collective.
  subroutine lump_finest(mc, fine, nodal, fixedg)
    type(mg_coarse_t), intent(inout) :: mc
    type(lattice_t), intent(in) :: fine
    type(node_blocks_t), intent(in) :: nodal
    logical, intent(in) :: fixedg(0:, fine%gys:)
    if (.not. allocated(mc%df)) allocate(mc%df(18, 0:fine%nx - 1, fine%gys:fine%gye))
    mc%df = 0.0_rp
    if (node_blocks_count(nodal) > 0) call node_blocks_lumped(nodal, fine%gys, fixedg, mc%df)
    if (mc%nranks > 1) call exchange_ghosts(mc, mc%df, fine%gys, fine%ys, fine%ye, fine%halo)
  end subroutine lump_finest

  !> Level l's node blocks: the level above's (df for l = 2) summed with
  !> the bilinear weights (1 at the coarse node, 1/2 and 1/4 at the fine
  !> nodes between; each fine node's weights sum to 1, so the total
  !> stiffness is kept, as the levels' masses are), a barrier's stiffness
  !> being, like the mass, of order zero (the bilinear Galerkin product is
  !> consistent there). Without blocks (blocks false) the level's list is
  !> emptied. Collective.
  subroutine level_blocks(mc, l, fine, blocks)
    type(mg_coarse_t), intent(inout), target :: mc
    integer, intent(in) :: l
    type(lattice_t), intent(in) :: fine
    logical, intent(in) :: blocks
    real(rp), pointer :: src(:, :, :)
    integer :: i, j, ia, jb, nxs
    real(rp) :: wgt
    associate (c => mc%lev(l))
      if (.not. blocks) then
        ! (a scene without node blocks never fills the list: nothing
        ! allocated; d is kept for the next blocks, no allocation in the loop)
        if (node_blocks_count(c%nodal) > 0) then
          call node_blocks_begin(c%nodal, c%lat%ys, c%lat%ye)
          call node_blocks_end(c%nodal)
        end if
        return
      end if
      call node_blocks_begin(c%nodal, c%lat%ys, c%lat%ye)
      if (.not. allocated(c%d)) allocate(c%d(18, 0:c%lat%nx - 1, c%lat%gys:c%lat%gye))
      if (l == 2) then
        src(1:, 0:, fine%gys:) => mc%df
        nxs = fine%nx
      else
        src(1:, 0:, mc%lev(l - 1)%lat%gys:) => mc%lev(l - 1)%d
        nxs = mc%lev(l - 1)%lat%nx
      end if
      c%d = 0.0_rp
      do j = c%j0, c%j1
        do jb = max(2 * j - 1, lbound(src, 3)), min(2 * j + 1, ubound(src, 3))
          do i = 0, c%lat%nx - 1
            do ia = max(2 * i - 1, 0), min(2 * i + 1, nxs - 1)
              wgt = (1.0_rp - 0.5_rp * abs(ia - 2 * i)) * (1.0_rp - 0.5_rp * abs(jb - 2 * j))
              c%d(:, i, j) = c%d(:, i, j) + wgt * src(:, ia, jb)
            end do
          end do
        end do
      end do
      call share_rows(mc, c, c%d)
      do j = c%lat%ys, c%lat%ye
        do i = 0, c%lat%nx - 1
          if (any(c%d(:, i, j) /= 0.0_rp)) then
            call node_blocks_add(c%nodal, i, j, reshape(c%d(1:9, i, j), [3, 3]), reshape(c%d(10:18, i, j), [3, 3]))
          end if
        end do
      end do
      call node_blocks_end(c%nodal)
    end associate
  end subroutine level_blocks

  !> Level c's state and constraint marks on its rows and ghost rows: its
  !> own rows injected from the finest ones, the rest from the other ranks.
  subroutine inject(mc, c, fine, u, fixedg)
    type(mg_coarse_t), intent(in) :: mc
    type(coarse_level_t), intent(inout) :: c
    type(lattice_t), intent(in) :: fine
    real(rp), intent(in) :: u(0:, 0:, fine%gys:)
    logical, intent(in) :: fixedg(0:, fine%gys:)
    integer :: i, j
    if (c%replicated .and. mc%nranks > 1) c%u = 0.0_rp
    call inject_rows(c%stride, u(0:5, :, :), fine%gys, c%u(0:5, :, :), c%lat%gys, c%j0, c%j1)
    do j = c%j0, c%j1
      do i = 0, c%lat%nx - 1
        c%u(6, i, j) = merge(1.0_rp, 0.0_rp, fixedg(c%stride * i, c%stride * j))
      end do
    end do
    call share_rows(mc, c, c%u)
    c%fixed = c%u(6, :, :) > 0.5_rp
  end subroutine inject

  !> Level c's rows of a(:, 0:nx-1, gys:gye) where this rank computed only
  !> its own (j0..j1, the rest zero): on a replicated level summed from
  !> every rank, on a distributed one its ghost rows from the neighbours
  !> (each owns at least halo rows of it: module stencil_mg keeps a level
  !> distributed only then). Collective.
  subroutine share_rows(mc, c, a)
    type(mg_coarse_t), intent(in) :: mc
    type(coarse_level_t), intent(in) :: c
    real(rp), intent(inout) :: a(:, 0:, c%lat%gys:)
    integer :: ierr
    if (mc%nranks == 1) return
    if (c%replicated) then
      call MPI_Allreduce(MPI_IN_PLACE, a, size(a), MPI_DOUBLE_PRECISION, MPI_SUM, mc%comm, ierr)
    else
      call exchange_ghosts(mc, a, c%lat%gys, c%lat%ys, c%lat%ye, c%lat%halo)
    end if
  end subroutine share_rows

  !> The h ghost rows on each side of a(:, 0:nx-1, gys:gye) (none beyond
  !> the lattice's ends), rows ys..ye this rank's, from the neighbours' rows.
  subroutine exchange_ghosts(mc, a, gys, ys, ye, h)
    type(mg_coarse_t), intent(in) :: mc
    integer, intent(in) :: gys, ys, ye, h
    real(rp), intent(inout) :: a(:, 0:, gys:)
    real(rp), allocatable :: sbuf(:, :, :), rbuf(:, :, :)
    integer :: cnt, ierr
    allocate(sbuf(size(a, 1), 0:size(a, 2) - 1, h), rbuf(size(a, 1), 0:size(a, 2) - 1, h))
    cnt = size(sbuf)
    ! my first rows to the rank below, the rank above's first rows to my top ghosts
    sbuf = a(:, :, ys:ys + h - 1)
    call MPI_Sendrecv(sbuf, cnt, MPI_DOUBLE_PRECISION, mc%below, 21, rbuf, cnt, MPI_DOUBLE_PRECISION, mc%above, 21, &
                      mc%comm, MPI_STATUS_IGNORE, ierr)
    if (mc%above /= MPI_PROC_NULL) a(:, :, ye + 1:ye + h) = rbuf
    ! my last rows to the rank above, the rank below's last rows to my bottom ghosts
    sbuf = a(:, :, ye - h + 1:ye)
    call MPI_Sendrecv(sbuf, cnt, MPI_DOUBLE_PRECISION, mc%above, 22, rbuf, cnt, MPI_DOUBLE_PRECISION, mc%below, 22, &
                      mc%comm, MPI_STATUS_IGNORE, ierr)
    if (mc%below /= MPI_PROC_NULL) a(:, :, ys - h:ys - 1) = rbuf
  end subroutine exchange_ghosts

end module mg_coarse
