! SPDX-License-Identifier: BSD-2-Clause
!> The rediscretised coarse levels of nuno's multigrid (issue 46;
!> -nuno_mg_coarse rediscretize): level l is the same cloth on the lattice
!> coarsened 2^(l-1) times (module coarse_lattice), at the finest state
!> injected (every 2^(l-1)-th node), with the same constraints, shift and
!> element model, and the process models' node blocks (contact) lumped
!> onto their nodes and summed with the bilinear weights level by level
!> (as the masses are; where some are blocks between neighbours, the
!> faces' contact, all of them by the Galerkin product of the bilinear
!> transfers instead, module coarse_lattice's restrict_offset_blocks),
!> assembled by the finest level's assembly (module
!> reduced_assembly's assemble_stencil) straight into the level's operator
!> (module stencil_mg's mg_level_op). Every level then has the finest
!> level's reach and offsets (16 blocks a node with bending, 8 without),
!> and a fourth-order part consistent with the finest one's, which the
!> bilinear Galerkin product is not (docs/performance.md).
!>
!> Parallel: a level's rows are injected, level by level, on the rank that
!> owns their parents (coarse row J's row 2 J on the level above: its
!> "natural" rows); a distributed level owns just those, and its ghost
!> rows are exchanged with the neighbours; a level gathered on fewer
!> ranks (module mg_gather) receives its rows and ghost rows from the
!> ranks that injected them, by a row plan made once; the replicated
!> coarsest level (several ranks) is summed from every rank's rows. Its
!> record has private components: only this module writes it.
module mg_coarse
  use mpi
  use kinds, only: rp
  use lattice, only: lattice_t, lattice_coarsened
  use coarse_lattice, only: mass_factors, restrict_factors, inject_rows, restrict_offset_blocks
  use node_blocks, only: node_blocks_t, node_blocks_count, node_blocks_lumped, node_blocks_begin, node_blocks_add, &
                         node_blocks_end, node_blocks_between, node_blocks_by_offset, node_blocks_add_pair
  use reduced_assembly, only: assemble_stencil
  use offset_product, only: offset_count
  use mg_kernels, only: stencil_t
  use stencil_mg, only: stencil_mg_t, mg_set_seam, mg_levels, mg_level_rows, mg_level_links, mg_level_op, mg_set_level_fixed, &
                        mg_factor_coarsest
  use mg_gather, only: row_plan_t, plan_create, plan_copy_dp, natural_rows
  implicit none
  private
  public :: mg_coarse_t, mg_coarse_init, mg_coarse_build, mg_coarse_free

  !> One coarse level's lattice, state and the assembly's work arrays.
  type :: coarse_level_t
    type(lattice_t) :: lat                         !< the cloth on this level's lattice (rows of this rank, ghosts)
    integer :: j0 = 0, j1 = -1                     !< the rows injected on this rank (their parents on the level above are its own)
    logical :: replicated = .false.                !< every rank holds every row (and assembles them)
    integer :: below = MPI_PROC_NULL, above = MPI_PROC_NULL !< the neighbours in this level's strips
    logical :: gathered = .false.                  !< on fewer ranks than the level above (module mg_gather)
    logical :: active = .true.                     !< this rank holds rows of the level
    type(row_plan_t) :: plan                       !< gathered: the injected rows j0..j1 to the owners' rows and ghosts
    real(rp), allocatable :: un(:, :, :)           !< (0:6, 0:nx-1, j0:j1) gathered: the injected rows of u
    real(rp), allocatable :: dn(:, :, :)           !< (18, 0:nx-1, j0:j1) gathered: the injected rows of d
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
    !> (18 x 9, 0:nx-1, gys:gye) the same by offset (-1..1)^2, the Galerkin
    !> product, where some blocks are between neighbours (allocated at the
    !> first rebuild with such blocks, then kept); dpn (18 x 9, 0:nx-1,
    !> j0:j1): its injected rows on a gathered level
    real(rp), allocatable :: dp(:, :, :), dpn(:, :, :)
    type(node_blocks_t) :: nodal                   !< d as this level's node blocks, for its assembly
  end type coarse_level_t

  type :: mg_coarse_t
    private
    integer :: comm = MPI_COMM_NULL, nranks = 1, below = MPI_PROC_NULL, above = MPI_PROC_NULL
    type(coarse_level_t), allocatable :: lev(:)    !< (2:nlev)
    !> (18, 0:nx-1, gys:gye) the finest level's node blocks lumped onto
    !> their nodes, with ghost rows (allocated at the first rebuild with any, then kept)
    real(rp), allocatable :: df(:, :, :)
    !> (18 x 9, 0:nx-1, gys:gye) the finest level's node blocks by offset,
    !> with ghost rows, where some are between neighbours (allocated at the
    !> first rebuild with such blocks, then kept)
    real(rp), allocatable :: dfo(:, :, :)
  end type mg_coarse_t

  !> The values a node's blocks take by offset: 18 (kx, kv) for each of 9
  integer, parameter :: NOFF = 18 * 9

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
    integer :: l, nx, ny, ys, ye, ierr, rank, pys, pye, nxp, nyp
    logical :: rep, prep
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
        c%replicated = rep
        c%active = ys <= ye
        call mg_level_links(mg, l, c%below, c%above, c%gathered)
        ! the rows whose parents on the level above this rank owns
        call mg_level_rows(mg, l - 1, nxp, nyp, pys, pye, prep)
        call natural_rows(pys, pye, c%j0, c%j1)
        call level_arrays(c)
        if (c%gathered) then
          allocate(c%un(0:6, 0:nx - 1, c%j0:c%j1))
          c%un = 0.0_rp
          call plan_create(c%plan, comm, 34, c%j0, c%j1, merge(c%lat%gys, 0, c%active), merge(c%lat%gye, -1, c%active))
        end if
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
    ! (1) node blocks on any rank (the restriction exchanges rows: all or
    ! none), (2) some of them between neighbours
    logical :: blocks(2)
    ierr = 0
    blocks(1) = node_blocks_count(nodal) > 0
    blocks(2) = node_blocks_between(nodal)
    if (mc%nranks > 1) call MPI_Allreduce(MPI_IN_PLACE, blocks, 2, MPI_LOGICAL, MPI_LOR, mc%comm, ierr)
    ! blocks between neighbours, the faces' barrier across an element, are
    ! of rank one: the smoother's Jacobi between strips does not damp them
    ! (stencil_mg's seam sweeps)
    call mg_set_seam(mg, blocks(2))
    if (blocks(2)) then
      call finest_by_offset(mc, fine, nodal, fixedg)
    else if (blocks(1)) then
      call lump_finest(mc, fine, nodal, fixedg)
    end if
    do l = 2, mg_levels(mg)
      associate (c => mc%lev(l))
        call inject(mc, l, fine, u, fixedg)
        if (blocks(2)) then
          call level_offset_blocks(mc, l, fine)
        else
          call level_blocks(mc, l, fine, blocks(1))
        end if
        if (.not. c%active) cycle
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
    if (mc%nranks > 1) call exchange_ghosts(mc%comm, mc%below, mc%above, mc%df, fine%gys, fine%ys, fine%ye, fine%halo)
  end subroutine lump_finest

  !> The finest level's node blocks by offset (dfo), with the neighbours'
  !> rows in the ghost rows. Collective.
  subroutine finest_by_offset(mc, fine, nodal, fixedg)
    type(mg_coarse_t), intent(inout) :: mc
    type(lattice_t), intent(in) :: fine
    type(node_blocks_t), intent(in) :: nodal
    logical, intent(in) :: fixedg(0:, fine%gys:)
    if (.not. allocated(mc%dfo)) allocate(mc%dfo(NOFF, 0:fine%nx - 1, fine%gys:fine%gye))
    mc%dfo = 0.0_rp
    call node_blocks_by_offset(nodal, fine%nx, fine%gys, fine%gye, fixedg, mc%dfo)
    if (mc%nranks > 1) call exchange_ghosts(mc%comm, mc%below, mc%above, mc%dfo, fine%gys, fine%ys, fine%ye, fine%halo)
  end subroutine finest_by_offset

  !> Level l's node blocks where some are between neighbours (the faces'
  !> contact): the Galerkin product of the level above's (dfo for l = 2)
  !> with the bilinear transfers, by offset, made on the rows injected
  !> here and shared as the state's rows are. Collective.
  subroutine level_offset_blocks(mc, l, fine)
    type(mg_coarse_t), intent(inout), target :: mc
    integer, intent(in) :: l
    type(lattice_t), intent(in) :: fine
    integer :: i, j, di, dj, k
    associate (c => mc%lev(l))
      if (.not. allocated(c%dp)) allocate(c%dp(NOFF, 0:c%lat%nx - 1, c%lat%gys:c%lat%gye))
      c%dp = 0.0_rp
      if (c%gathered .and. .not. allocated(c%dpn)) allocate(c%dpn(NOFF, 0:c%lat%nx - 1, c%j0:c%j1))
      if (l == 2) then
        call restrict_into(fine%nx, fine%gys, fine%gye, mc%dfo)
      else
        associate (p => mc%lev(l - 1))
          call restrict_into(p%lat%nx, p%lat%gys, p%lat%gye, p%dp)
        end associate
      end if
      call share_rows(mc, c, c%dp, c%dpn)
      if (.not. c%active) return
      call node_blocks_begin(c%nodal, c%lat%ys, c%lat%ye)
      do j = c%lat%ys, c%lat%ye
        do i = 0, c%lat%nx - 1
          do dj = -1, 1
            do di = -1, 1
              k = 18 * (3 * (dj + 1) + di + 1)
              if (all(c%dp(k + 1:k + 18, i, j) == 0.0_rp)) cycle
              call node_blocks_add_pair(c%nodal, i, j, di, dj, reshape(c%dp(k + 1:k + 9, i, j), [3, 3]), &
                                        reshape(c%dp(k + 10:k + 18, i, j), [3, 3]))
            end do
          end do
        end do
      end do
      call node_blocks_end(c%nodal)
    end associate
  contains
    !> This rank's injected rows of level l (into dpn where gathered) from
    !> src, the level above's rows gys..gye by offset.
    subroutine restrict_into(nxs, gys, gye, src)
      integer, intent(in) :: nxs, gys, gye
      real(rp), intent(in) :: src(:, :, :)
      associate (c => mc%lev(l))
        if (c%gathered) then
          c%dpn = 0.0_rp
          call restrict_offset_blocks(nxs, gys, gye, src, c%lat%nx, c%lat%ny, c%j0, c%j1, c%j0, c%j1, c%dpn)
        else
          call restrict_offset_blocks(nxs, gys, gye, src, c%lat%nx, c%lat%ny, c%lat%gys, c%lat%gye, c%j0, c%j1, c%dp)
        end if
      end associate
    end subroutine restrict_into
  end subroutine level_offset_blocks

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
    real(rp), pointer :: src(:, :, :), dst(:, :, :)
    integer :: i, j, ia, jb, nxs
    real(rp) :: wgt
    associate (c => mc%lev(l))
      if (.not. blocks .and. c%active) then
        ! (a scene without node blocks never fills the list: nothing
        ! allocated; d is kept for the next blocks, no allocation in the loop)
        if (node_blocks_count(c%nodal) > 0) then
          call node_blocks_begin(c%nodal, c%lat%ys, c%lat%ye)
          call node_blocks_end(c%nodal)
        end if
        return
      end if
      if (.not. blocks) return
      if (.not. allocated(c%d)) allocate(c%d(18, 0:c%lat%nx - 1, c%lat%gys:c%lat%gye))
      c%d = 0.0_rp
      dst(1:, 0:, c%lat%gys:) => c%d
      if (c%gathered) then
        ! this rank's injected rows first, then to their owners
        if (.not. allocated(c%dn)) allocate(c%dn(18, 0:c%lat%nx - 1, c%j0:c%j1))
        c%dn = 0.0_rp
        dst(1:, 0:, c%j0:) => c%dn
      end if
      if (l == 2) then
        src(1:, 0:, fine%gys:) => mc%df
        nxs = fine%nx
      else
        src(1:, 0:, mc%lev(l - 1)%lat%gys:) => mc%lev(l - 1)%d
        nxs = mc%lev(l - 1)%lat%nx
      end if
      do j = c%j0, c%j1
        do jb = max(2 * j - 1, lbound(src, 3)), min(2 * j + 1, ubound(src, 3))
          do i = 0, c%lat%nx - 1
            do ia = max(2 * i - 1, 0), min(2 * i + 1, nxs - 1)
              wgt = (1.0_rp - 0.5_rp * abs(ia - 2 * i)) * (1.0_rp - 0.5_rp * abs(jb - 2 * j))
              dst(:, i, j) = dst(:, i, j) + wgt * src(:, ia, jb)
            end do
          end do
        end do
      end do
      call share_rows(mc, c, c%d, c%dn)
      if (.not. c%active) return
      call node_blocks_begin(c%nodal, c%lat%ys, c%lat%ye)
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

  !> Level l's state and constraint marks on its rows and ghost rows: the
  !> rows j0..j1 injected from the level above (level 2: from the finest
  !> state u and marks fixedg; below, the level above's state and marks,
  !> the same values), the rest from the other ranks. Collective.
  subroutine inject(mc, l, fine, u, fixedg)
    type(mg_coarse_t), intent(inout), target :: mc
    integer, intent(in) :: l
    type(lattice_t), intent(in) :: fine
    real(rp), intent(in) :: u(0:, 0:, fine%gys:)
    logical, intent(in) :: fixedg(0:, fine%gys:)
    real(rp), pointer :: dst(:, :, :)
    integer :: i, j
    associate (c => mc%lev(l))
      if (c%replicated .and. mc%nranks > 1) c%u = 0.0_rp
      dst(0:, 0:, c%lat%gys:) => c%u
      if (c%gathered) dst(0:, 0:, c%j0:) => c%un
      if (l == 2) then
        call inject_rows(2, u(0:5, :, :), fine%gys, dst(0:5, :, :), lbound(dst, 3), c%j0, c%j1)
        do j = c%j0, c%j1
          do i = 0, c%lat%nx - 1
            dst(6, i, j) = merge(1.0_rp, 0.0_rp, fixedg(2 * i, 2 * j))
          end do
        end do
      else
        call inject_rows(2, mc%lev(l - 1)%u, mc%lev(l - 1)%lat%gys, dst, lbound(dst, 3), c%j0, c%j1)
      end if
      call share_rows(mc, c, c%u, c%un)
      if (c%active) c%fixed = c%u(6, :, :) > 0.5_rp
    end associate
  end subroutine inject

  !> Level c's rows of a(:, 0:nx-1, gys:gye) where this rank computed only
  !> its natural rows (j0..j1): on a replicated level (the rest zero)
  !> summed from every rank, on a distributed one its ghost rows from the
  !> neighbours (each owns at least halo rows of it: module stencil_mg
  !> keeps a level distributed only then), on a gathered one (computed in
  !> an(:, 0:nx-1, j0:j1) instead) its rows and ghost rows from the ranks
  !> that computed them (c%plan). Collective.
  subroutine share_rows(mc, c, a, an)
    type(mg_coarse_t), intent(in) :: mc
    type(coarse_level_t), intent(inout) :: c
    real(rp), intent(inout) :: a(:, 0:, c%lat%gys:)
    real(rp), intent(in), allocatable :: an(:, :, :)   !< gathered levels only (else not allocated)
    integer :: ierr
    if (c%gathered) then
      call plan_copy_dp(c%plan, size(a, 1) * size(a, 2), an, c%j0, a, c%lat%gys)
    else if (mc%nranks == 1) then
      return
    else if (c%replicated) then
      call MPI_Allreduce(MPI_IN_PLACE, a, size(a), MPI_DOUBLE_PRECISION, MPI_SUM, mc%comm, ierr)
    else if (c%active) then
      call exchange_ghosts(mc%comm, c%below, c%above, a, c%lat%gys, c%lat%ys, c%lat%ye, c%lat%halo)
    end if
  end subroutine share_rows

  !> The h ghost rows on each side of a(:, 0:nx-1, gys:gye) (none beyond
  !> the lattice's ends), rows ys..ye this rank's, from the neighbours'
  !> rows (ranks below and above on comm; MPI_PROC_NULL at the ends).
  subroutine exchange_ghosts(comm, below, above, a, gys, ys, ye, h)
    integer, intent(in) :: comm, below, above
    integer, intent(in) :: gys, ys, ye, h
    real(rp), intent(inout) :: a(:, 0:, gys:)
    real(rp), allocatable :: sbuf(:, :, :), rbuf(:, :, :)
    integer :: cnt, ierr
    allocate(sbuf(size(a, 1), 0:size(a, 2) - 1, h), rbuf(size(a, 1), 0:size(a, 2) - 1, h))
    cnt = size(sbuf)
    ! my first rows to the rank below, the rank above's first rows to my top ghosts
    sbuf = a(:, :, ys:ys + h - 1)
    call MPI_Sendrecv(sbuf, cnt, MPI_DOUBLE_PRECISION, below, 21, rbuf, cnt, MPI_DOUBLE_PRECISION, above, 21, &
                      comm, MPI_STATUS_IGNORE, ierr)
    if (above /= MPI_PROC_NULL) a(:, :, ye + 1:ye + h) = rbuf
    ! my last rows to the rank above, the rank below's last rows to my bottom ghosts
    sbuf = a(:, :, ye - h + 1:ye)
    call MPI_Sendrecv(sbuf, cnt, MPI_DOUBLE_PRECISION, above, 22, rbuf, cnt, MPI_DOUBLE_PRECISION, below, 22, &
                      comm, MPI_STATUS_IGNORE, ierr)
    if (below /= MPI_PROC_NULL) a(:, :, ys - h:ys - 1) = rbuf
  end subroutine exchange_ghosts

end module mg_coarse
