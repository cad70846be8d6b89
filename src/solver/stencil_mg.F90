! SPDX-License-Identifier: BSD-2-Clause
!> nuno's structured multigrid for the reduced system S dv = rhs (the
!> default inner preconditioner, docs/design.md): geometric levels of the
!> lattice (vertex-centred 2:1 coarsening), Galerkin coarse operators
!> P^T A P, block Gauss-Seidel smoothing, a banded LU of the coarsest level
!> on every rank. Every level is a strip of whole rows per rank, as the
!> DMDA's; its operator and vectors are in module mg_kernels' single-precision
!> stencil storage (no column indices, no PETSc matrix). MPI only for the
!> halo rows between neighbouring strips and for the coarsest level; no
!> PETSc (module reduced is the glue).
!>
!> Ownership: coarse row J belongs to the rank that owns fine row 2 J.
!> A level is kept distributed while every rank owns at least its halo
!> (the stencil reach, and the rows the transfers reach beyond the strip)
!> of it. The first level where that fails is, on more than 4 ranks
!> (-nuno_mg_gather auto), gathered on fewer: split over the first
!> k ranks with hc rows each at least (module mg_gather: the transfers
!> into and out of it exchange rows point to point), and so on down; the
!> others idle on it and below. The last level of the hierarchy, or the
!> first that fails on at most 4 ranks (or on any with
!> -nuno_mg_gather never), is the coarsest: replicated on every rank
!> (each rank's partial sums of its right-hand side and Galerkin operator
!> are summed over all ranks) and solved directly.
!>
!> Cycles: multiplicative (a V-cycle: nu symmetric Gauss-Seidel sweeps
!> before and after the coarse correction) or kaskade (the right-hand side
!> restricted to the coarsest level, solved there, then interpolated up
!> with nu symmetric sweeps on each level and no return to coarser ones:
!> the cheapest application, PETSc's PC_MG_KASKADE).
module stencil_mg
  use mpi
  use kinds, only: rp
  use solver_choices, only: CYCLE_V, CYCLE_W, CYCLE_KASKADE
  use mg_kernels, only: mp, stencil_t, transfer_t, stencil_init, stencil_put_row, stencil_finish, stencil_from_full, transfer_init, offset_index, &
                        stencil_block, diagonal_block, &
                        coarse_reach, gs_sweep, residual, interpolate, restrict_add, galerkin_add, level_product_rows, &
                        stencil_product_mixed
  use mg_strips, only: strip_exchange, strip_sums_w, strip_sums_ac
  use mg_gather, only: level_gather_t, gather_init, gather_on, gather_restrict, gather_interpolate, gather_galerkin, coarse_layout, &
                       natural_rows
  implicit none
  private
  public :: stencil_mg_t, mg_set_seam, mg_create, mg_destroy, mg_set_fine_row, mg_set_fine, mg_fine_level, mg_build_coarse, mg_apply, mg_describe, &
            mg_product, mg_levels, mg_level_rows, mg_level_links, mg_level_op, mg_set_level_fixed, mg_factor_coarsest
  type :: mg_level_t
    type(stencil_t) :: a                         !< the operator (rows ys..ye)
    integer :: h = 0                             !< padding rows and columns of the vectors
    logical :: replicated = .false.              !< every rank holds every row (the coarsest level)
    real(mp), allocatable :: x(:, :, :)          !< (-h:nx-1+h, 3, ys-h:ye+h) solution
    real(mp), allocatable :: w(:, :, :)          !< (-h:nx-1+h, 3, ys-h:ye+h) restriction sums (with other ranks' rows)
    real(mp), allocatable :: rhs(:, :, :)        !< (0:nx-1, 3, ys:ye) right-hand side
    real(mp), allocatable :: res(:, :, :)        !< (0:nx-1, 3, ys:ye) residual
    real(mp), allocatable :: t(:, :)             !< (0:nx-1, 3) row work
    real(mp), allocatable :: low(:, :, :)        !< (0:nx-1, 3, ys:ye) a forward sweep's rhs minus the sums over the rows below (gs_sweep)
    type(transfer_t) :: tx, ty                   !< from the next coarser level to this one: restriction, Galerkin product
    type(transfer_t) :: ux, uy                   !< the same, for the interpolation of the coarse correction (tx, ty unless cubic_correction)
    logical :: cubic = .false., cubic_up = .false. !< tx, ty cubic; ux, uy cubic
    !> (2, n) the owned constrained nodes (i, j) of a rediscretised coarse
    !> level (mg_set_level_fixed): their restricted right-hand side is
    !> zeroed, so the coarse correction is zero there, as the fine one is
    !> (an interpolation without their columns)
    integer, allocatable :: fixed(:, :)
    !> (0:nx-1, 3, 3, -r:r, -r:r, ys-h:ye+h) Galerkin sums of this level:
    !> during mg_build_coarse only, over the hierarchy's work array acw
    real(rp), pointer, contiguous :: ac(:, :, :, :, :, :) => null()
    integer(kind=8) :: nac = 0                   !< the size of ac
    real(rp), allocatable :: bx(:, :, :, :, :)    !< (0:nx-1, 3, 3, -r:r, -rf:rf) work of galerkin_add (rf: the finer level's reach)
    real(rp), allocatable :: rw(:, :, :, :)      !< (0:nx-1, 3, 3, 2) work of galerkin_add on this level's rows (all but the coarsest)
    !> (0:nx-1, 3, 3, -r:r, -r:r, h) the neighbour rank's Galerkin sums of
    !> this rank's rows, received (finish_sums_ac; a level split over ranks)
    real(rp), allocatable :: acbuf(:, :, :, :, :, :)
    !> this level's neighbours in its strips (MPI_PROC_NULL at the ends,
    !> where replicated and where this rank holds none of its rows)
    integer :: below = MPI_PROC_NULL, above = MPI_PROC_NULL
    type(level_gather_t) :: gat                  !< gathered on fewer ranks: the link to the level above (module mg_gather)
  end type mg_level_t

  !> The hierarchy: lev(1) is the lattice itself.
  type :: stencil_mg_t
    integer :: comm = MPI_COMM_NULL, rank = 0, nranks = 1, below = MPI_PROC_NULL, above = MPI_PROC_NULL
    integer :: nlev = 0
    integer :: cycle_type = CYCLE_V
    integer :: nu = 1                            !< symmetric Gauss-Seidel sweeps per smoothing (the finest level)
    integer :: gamma = 1                         !< cycles on the next level per visit (1: V-cycle, 2: W-cycle)
    !> coarse levels rediscretised (set by the caller, module mg_coarse:
    !> the lattice's reach and offsets, mg_level_op) instead of Galerkin
    !> products (mg_build_coarse)
    logical :: rediscretize = .false.
    logical :: seam = .false.                    !< seam sweeps (smooth; set by module mg_coarse)
    type(mg_level_t), allocatable :: lev(:)
    ! the coarsest level's banded LU (LAPACK dgbtrf), same on every rank
    integer :: n = 0, kl = 0
    real(rp), allocatable :: ab(:, :)            !< (3 kl + 1, n)
    real(rp), allocatable :: xc(:)               !< (n)
    integer, allocatable :: ipiv(:)              !< (n)
    !> the Galerkin sums of one coarse level at a time (the largest's size):
    !> they are needed only while that level is built from them
    real(rp), pointer, contiguous :: acw(:) => null()
    !> work of the products with the finest level (mg_product, and the one
    !> formed in its last sweep: mg_apply's ax): 2 r + 1 rows of x, one row
    !> of the product, one offset's differences
    real(rp), allocatable :: pxs(:, :, :)        !< (-r:nx-1+r, 3, 0:2r)
    real(rp), allocatable :: pacc(:, :)          !< (0:nx-1, 4)
    real(mp), allocatable :: pds(:, :)           !< (0:nx-1, 3)
  end type stencil_mg_t

  interface
    !> Lines that describe the hierarchy, for -reduced_ksp_view (submodule
    !> stencil_mg_describe). Collective.
    module subroutine mg_describe(mg, text, n)
      type(stencil_mg_t), intent(in) :: mg
      character(len=*), intent(out) :: text(:)
      integer, intent(out) :: n
    end subroutine mg_describe
  end interface

contains

  !> Build the levels of an nx x ny lattice whose rows ys..ye this rank
  !> owns (strips of 1 x P ranks, in rank order), with stencil reach r on
  !> the lattice. cubic(l) (l = 1, 2, ...): cubic transfer between level
  !> l + 1 and level l, else bilinear. cubic_correction(l) (default
  !> cubic(l)): the coarse correction interpolated cubic from level l + 1
  !> even where cubic(l) is false, the restriction and the Galerkin product
  !> staying bilinear: on the finest level with bending, 9-10 % fewer
  !> Krylov iterations on hang 129..513 for a bilinear level 2 (a cubic
  !> Galerkin product widens it to reach 3 and costs as many as it saves;
  !> measured with commit e284754). At most max_levels levels;
  !> coarsening stops at 5 points a side. rediscretize: the coarse levels
  !> are the caller's (the cloth on the coarse lattice: module mg_coarse),
  !> of the finest level's reach and offsets, set through mg_level_op,
  !> and mg_factor_coarsest; no Galerkin sums are kept. gather
  !> (-nuno_mg_gather auto): a level too thin for the strips of more than
  !> 4 ranks is gathered on fewer (module mg_gather, coarse_layout)
  !> instead of being the replicated coarsest. Collective.
  subroutine mg_create(mg, comm, nx, ny, ys, ye, r, cubic, max_levels, cycle_type, nu, cubic_correction, paired, rediscretize, &
                       gather)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: comm, nx, ny, ys, ye, r, max_levels, cycle_type, nu
    logical, intent(in) :: cubic(:)
    logical, intent(in), optional :: cubic_correction(:)
    !> the operators the caller will set are paired (stencil_t; S without
    !> bending): every level's, as a Galerkin product keeps it so
    logical, intent(in), optional :: paired
    logical, intent(in), optional :: rediscretize
    logical, intent(in), optional :: gather
    type(mg_level_t), allocatable :: tmp(:)
    integer :: ierr, l, nxc, nyc, ysc, yec, rc, hc, k, below, above
    logical :: last, gathered, may_gather, short

    mg%comm = comm
    call MPI_Comm_rank(comm, mg%rank, ierr)
    call MPI_Comm_size(comm, mg%nranks, ierr)
    mg%below = merge(mg%rank - 1, MPI_PROC_NULL, mg%rank > 0)
    mg%above = merge(mg%rank + 1, MPI_PROC_NULL, mg%rank < mg%nranks - 1)
    mg%cycle_type = cycle_type
    mg%gamma = merge(2, 1, cycle_type == CYCLE_W)
    mg%nu = max(nu, 1)
    mg%rediscretize = .false.
    if (present(rediscretize)) mg%rediscretize = rediscretize
    may_gather = .false.
    if (present(gather)) may_gather = gather

    allocate(mg%lev(max(max_levels, 1)))
    call stencil_init(mg%lev(1)%a, nx, ny, ys, ye, r, lines=.true.)
    mg%lev(1)%h = r
    mg%lev(1)%replicated = mg%nranks == 1
    mg%lev(1)%below = mg%below
    mg%lev(1)%above = mg%above
    allocate(mg%pxs(-r:nx - 1 + r, 3, 0:2 * r), mg%pacc(0:nx - 1, 4), mg%pds(0:nx - 1, 3))
    l = 1
    last = max_levels <= 1
    do while (.not. last)
      associate (f => mg%lev(l))
        if (mod(f%a%nx - 1, 2) /= 0 .or. mod(f%a%ny - 1, 2) /= 0) exit
        nxc = (f%a%nx - 1) / 2 + 1
        nyc = (f%a%ny - 1) / 2 + 1
        if (min(nxc, nyc) < 5) exit
        f%cubic = cubic(min(l, size(cubic)))
        f%cubic_up = f%cubic
        if (present(cubic_correction)) f%cubic_up = f%cubic_up .or. cubic_correction(min(l, size(cubic_correction)))
        call transfer_init(f%tx, f%a%nx, f%cubic)
        call transfer_init(f%ty, f%a%ny, f%cubic)
        call transfer_init(f%ux, f%a%nx, f%cubic_up)
        call transfer_init(f%uy, f%a%ny, f%cubic_up)
        if (mg%rediscretize) then
          rc = r
        else
          rc = max(coarse_reach(f%tx, f%a%r), coarse_reach(f%ty, f%a%r))
        end if
        ! Coarse rows of this rank, and how far its fine rows' parents
        ! reach beyond them (restriction and interpolation cross that far);
        ! none where this rank holds no row of f (idle below a gathering).
        call natural_rows(f%a%ys, f%a%ye, ysc, yec)
        below = f%below
        above = f%above
        hc = rc
        do k = f%a%ys, f%a%ye
          hc = max(hc, ysc - minval(f%ty%c(1:f%ty%n(k), k)), maxval(f%ty%c(1:f%ty%n(k), k)) - yec, &
                   ysc - minval(f%uy%c(1:f%uy%n(k), k)), maxval(f%uy%c(1:f%uy%n(k), k)) - yec)
        end do
        call MPI_Allreduce(MPI_IN_PLACE, hc, 1, MPI_INTEGER, MPI_MAX, comm, ierr)
        short = l + 1 >= max_levels .or. min((nxc - 1) / 2 + 1, (nyc - 1) / 2 + 1) < 5 &
                .or. mod(nxc - 1, 2) /= 0 .or. mod(nyc - 1, 2) /= 0
        call coarse_layout(comm, f%a%ye >= f%a%ys, nyc, hc, short, may_gather, ysc, yec, below, above, gathered, last)
      end associate
      l = l + 1
      call stencil_init(mg%lev(l)%a, nxc, nyc, ysc, yec, rc, lines=mg%rediscretize)
      mg%lev(l)%h = hc
      mg%lev(l)%replicated = last .or. mg%nranks == 1
      mg%lev(l)%below = merge(MPI_PROC_NULL, below, mg%lev(l)%replicated)
      mg%lev(l)%above = merge(MPI_PROC_NULL, above, mg%lev(l)%replicated)
      if (gathered) then
        associate (f => mg%lev(l - 1), c => mg%lev(l))
          call gather_init(c%gat, comm, nxc, nyc, hc, rc, f%a%ys, f%a%ye, ysc, yec, .not. mg%rediscretize)
        end associate
      end if
    end do
    mg%nlev = l
    if (mg%nlev < size(mg%lev)) then
      allocate(tmp(mg%nlev))
      tmp = mg%lev(1:mg%nlev)
      call move_alloc(tmp, mg%lev)
    end if
    do l = 1, mg%nlev
      call level_arrays(mg%lev(l))
      if (present(paired)) mg%lev(l)%a%paired = paired
    end do
    do l = 2, mg%nlev
      if (mg%rediscretize) exit
      call level_sums(mg%lev(l))
      associate (c => mg%lev(l)%a)
        allocate(mg%lev(l)%bx(0:c%nx - 1, 3, 3, -c%r:c%r, -mg%lev(l - 1)%a%r:mg%lev(l - 1)%a%r))
        allocate(mg%lev(l - 1)%rw(0:mg%lev(l - 1)%a%nx - 1, 3, 3, 2))
      end associate
    end do
    if (associated(mg%acw)) deallocate(mg%acw)
    allocate(mg%acw(max(1_8, maxval([(mg%lev(l)%nac, l = 1, mg%nlev)]))))
    ! The coarsest level's band: node-major unknowns 3 (i + nx j) + c.
    associate (c => mg%lev(mg%nlev))
      mg%n = 3 * c%a%nx * c%a%ny
      mg%kl = 3 * (c%a%r * c%a%nx + c%a%r) + 2
      allocate(mg%ab(3 * mg%kl + 1, mg%n), mg%xc(mg%n), mg%ipiv(mg%n))
    end associate
  end subroutine mg_create

  subroutine level_arrays(lv)
    type(mg_level_t), intent(inout) :: lv
    integer :: nx, ys, ye, h
    nx = lv%a%nx
    ys = lv%a%ys
    ye = lv%a%ye
    h = lv%h
    allocate(lv%x(-h:nx - 1 + h, 3, ys - h:ye + h), lv%w(-h:nx - 1 + h, 3, ys - h:ye + h))
    allocate(lv%rhs(0:nx - 1, 3, ys:ye), lv%res(0:nx - 1, 3, ys:ye), lv%t(0:nx - 1, 3), lv%low(0:nx - 1, 3, ys:ye))
    lv%x = 0.0_mp
    lv%w = 0.0_mp
    lv%rhs = 0.0_mp
    lv%res = 0.0_mp
    lv%low = 0.0_mp
  end subroutine level_arrays

  !> The size of a coarse level's Galerkin sums and its buffer for the
  !> neighbour's (none on the finest: its operator is S itself; allocated
  !> there too, they were 648 B a node without bending and 1.8 KB with,
  !> never used). The sums themselves go into the hierarchy's work array,
  !> one level at a time (mg_build_coarse): kept for every level between
  !> rebuilds, they were about 1 KB a node with bending.
  subroutine level_sums(lv)
    type(mg_level_t), intent(inout) :: lv
    integer :: nx, ys, ye, h, r
    nx = lv%a%nx
    ys = lv%a%ys
    ye = lv%a%ye
    h = lv%h
    r = lv%a%r
    lv%nac = int(nx, 8) * 9 * int(2 * r + 1, 8)**2 * int(ye - ys + 1 + 2 * h, 8)
    if (.not. lv%replicated .and. .not. gather_on(lv%gat)) allocate(lv%acbuf(0:nx - 1, 3, 3, -r:r, -r:r, h))
  end subroutine level_sums

  subroutine mg_destroy(mg)
    type(stencil_mg_t), intent(inout) :: mg
    if (allocated(mg%lev)) deallocate(mg%lev)
    if (allocated(mg%ab)) deallocate(mg%ab, mg%xc, mg%ipiv)
    if (associated(mg%acw)) deallocate(mg%acw)
    if (allocated(mg%pxs)) deallocate(mg%pxs, mg%pacc, mg%pds)
    mg%nlev = 0
  end subroutine mg_destroy

  !> The finest level's block row of node (i, j) (owned): blk(3, 3, -r:r,
  !> -r:r) = S(p, p + (di, dj)), zero outside the lattice.
  subroutine mg_set_fine_row(mg, i, j, blk)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: i, j
    real(rp), intent(in) :: blk(:, :, :, :)
    call stencil_put_row(mg%lev(1)%a, i, j, blk)
  end subroutine mg_set_fine_row

  !> The finest level from S by stencil offset, nodes fastest,
  !> full(0:nx-1, 3, 3, offset_slot(r, di, dj), ys:ye) = S(p, p + (di, dj))
  !> (module offset_product; double precision, zero outside the lattice).
  subroutine mg_set_fine(mg, full)
    type(stencil_mg_t), intent(inout) :: mg
    real(rp), intent(in) :: full(:, :, :, :, :)
    call stencil_from_full(mg%lev(1)%a, full)
  end subroutine mg_set_fine

  !> The finest level's operator, for an assembly that writes it row by
  !> row as it goes (module reduced_assembly's assemble_stencil converts
  !> each row of S as soon as it is complete): the one way into the
  !> hierarchy's level storage from outside, valid while mg lives and
  !> until mg_build_coarse, which reads it.
  function mg_fine_level(mg) result(fine)
    type(stencil_mg_t), intent(inout), target :: mg
    type(stencil_t), pointer :: fine
    fine => mg%lev(1)%a
  end function mg_fine_level

  !> The number of levels.
  pure integer function mg_levels(mg)
    type(stencil_mg_t), intent(in) :: mg
    mg_levels = mg%nlev
  end function mg_levels

  !> Level l's lattice (nx x ny), the rows ys..ye it holds on this rank
  !> and whether it is replicated (every rank holds every row: the
  !> coarsest level on several ranks, every level on one).
  subroutine mg_level_rows(mg, l, nx, ny, ys, ye, replicated)
    type(stencil_mg_t), intent(in) :: mg
    integer, intent(in) :: l
    integer, intent(out) :: nx, ny, ys, ye
    logical, intent(out) :: replicated
    nx = mg%lev(l)%a%nx
    ny = mg%lev(l)%a%ny
    ys = mg%lev(l)%a%ys
    ye = mg%lev(l)%a%ye
    replicated = mg%lev(l)%replicated
  end subroutine mg_level_rows

  !> Level l's neighbours in its strips (MPI_PROC_NULL at the ends, where
  !> replicated and where this rank holds none of its rows) and whether
  !> it is gathered on fewer ranks than the level above (module mg_gather).
  subroutine mg_level_links(mg, l, below, above, gathered)
    type(stencil_mg_t), intent(in) :: mg
    integer, intent(in) :: l
    integer, intent(out) :: below, above
    logical, intent(out) :: gathered
    below = mg%lev(l)%below
    above = mg%lev(l)%above
    gathered = gather_on(mg%lev(l)%gat)
  end subroutine mg_level_links

  !> Level l's operator, for a caller that writes it (the finest level:
  !> mg_fine_level; rediscretised coarse levels: module mg_coarse), valid
  !> while mg lives.
  function mg_level_op(mg, l) result(op)
    type(stencil_mg_t), intent(inout), target :: mg
    integer, intent(in) :: l
    type(stencil_t), pointer :: op
    op => mg%lev(l)%a
  end function mg_level_op

  !> The constrained nodes of rediscretised coarse level l, fixed(0:nx-1,
  !> ys:ye) of its rows on this rank: the restriction gives them no
  !> right-hand side (their rows are a m I alone, so their correction is
  !> zero, as on the finest level; with the restricted residual there,
  !> the coarse solve returned r / (a m), which the interpolation spread
  !> over the free fine nodes around: the scalar model's two-grid factor
  !> grew 0.64 -> 9.5 -> 152 at 33, 65, 129; bench/mg46/redisc.py).
  subroutine mg_set_level_fixed(mg, l, fixed)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: l
    logical, intent(in) :: fixed(0:, mg%lev(l)%a%ys:)
    integer :: i, j, n
    associate (lv => mg%lev(l))
      if (allocated(lv%fixed)) deallocate(lv%fixed)
      allocate(lv%fixed(2, count(fixed)))
      n = 0
      do j = lv%a%ys, lv%a%ye
        do i = 0, lv%a%nx - 1
          if (.not. fixed(i, j)) cycle
          n = n + 1
          lv%fixed(:, n) = [i, j]
        end do
      end do
    end associate
  end subroutine mg_set_level_fixed

  !> The coarse operators from the finest one (Galerkin, level by level)
  !> and the coarsest level's factorisation. ierr /= 0: the coarsest
  !> matrix is singular (LAPACK's info). Collective.
  subroutine mg_build_coarse(mg, ierr)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(out) :: ierr
    integer :: l
    ierr = 0
    ! (an internal invariant: the caller makes rediscretised levels, module mg_coarse)
    if (mg%rediscretize) error stop 'mg_build_coarse: the coarse levels are rediscretised'
    do l = 2, mg%nlev
      associate (f => mg%lev(l - 1), c => mg%lev(l))
        c%ac(0:c%a%nx - 1, 1:3, 1:3, -c%a%r:c%a%r, -c%a%r:c%a%r, c%a%ys - c%h:c%a%ye + c%h) => mg%acw(1:c%nac)
        c%ac = 0.0_rp
        if (gather_on(c%gat)) then
          call gather_galerkin(c%gat, f%a, f%tx, f%ty, c%a%r, c%a%ys, c%ac, c%bx, f%rw)
        else
          if (f%a%ye >= f%a%ys) call galerkin_add(f%a, f%tx, f%ty, c%a%r, c%a%ys - c%h, c%ac, c%bx, f%rw)
          call finish_sums_ac(mg, c)
        end if
        if (c%a%ye >= c%a%ys) call stencil_finish(c%a, c%ac(:, :, :, :, :, c%a%ys:c%a%ye))
        nullify(c%ac)
      end associate
    end do
    call mg_factor_coarsest(mg, ierr)
  end subroutine mg_build_coarse

  !> The coarsest level's banded LU (LAPACK dgbtrf) from its operator as
  !> stored (made by mg_build_coarse, or set by the caller: mg_level_op).
  !> ierr /= 0: the matrix is singular (LAPACK's info). Every rank alike.
  subroutine mg_factor_coarsest(mg, ierr)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(out) :: ierr
    integer :: j, i, di, dj, c1, c2, row, col, n
    ! Banded LU of the coarsest level (full blocks from its stored
    ! difference form, or the finest level's rows on one level).
    associate (c => mg%lev(mg%nlev))
      mg%ab = 0.0_rp
      n = mg%n
      do j = 0, c%a%ny - 1
        do i = 0, c%a%nx - 1
          do dj = -c%a%r, c%a%r
            if (j + dj < 0 .or. j + dj >= c%a%ny) cycle
            do di = -c%a%r, c%a%r
              if (i + di < 0 .or. i + di >= c%a%nx) cycle
              do c2 = 1, 3
                do c1 = 1, 3
                  row = 3 * (i + c%a%nx * j) + c1
                  col = 3 * ((i + di) + c%a%nx * (j + dj)) + c2
                  mg%ab(2 * mg%kl + 1 + row - col, col) = block_entry(c, i, j, di, dj, c1, c2)
                end do
              end do
            end do
          end do
        end do
      end do
      call dgbtrf(n, n, mg%kl, mg%kl, mg%ab, 3 * mg%kl + 1, mg%ipiv, ierr)
    end associate
  contains
    !> Entry (c1, c2) of block A(p, p + (di, dj)) of the coarsest level,
    !> from its stored difference form (the diagonal block is D - sum B).
    real(rp) function block_entry(c, i, j, di, dj, c1, c2) result(v)
      type(mg_level_t), intent(in) :: c
      integer, intent(in) :: i, j, di, dj, c1, c2
      real(rp) :: blk(3, 3)
      integer :: k
      if (di == 0 .and. dj == 0) then
        blk = diagonal_block(c%a, i, j)
        v = blk(c1, c2)
      else
        k = offset_index(c%a, di, dj)
        v = 0.0_rp
        if (k > 0) then
          blk = stencil_block(c%a, i, j, k)
          v = blk(c1, c2)
        end if
      end if
    end function block_entry
  end subroutine mg_factor_coarsest

  !> The Galerkin sums of level c as every rank's partial sums added where
  !> they belong: over all ranks for a replicated level, else the rows
  !> computed for the neighbours' strips sent to them and added.
  subroutine finish_sums_ac(mg, c)
    type(stencil_mg_t), intent(inout) :: mg
    type(mg_level_t), intent(inout) :: c
    integer :: ierr, cnt
    if (c%replicated) then
      if (mg%nranks > 1) then
        cnt = size(c%ac(:, :, :, :, :, c%a%ys:c%a%ye))
        call MPI_Allreduce(MPI_IN_PLACE, c%ac(0, 1, 1, -c%a%r, -c%a%r, c%a%ys), cnt, MPI_DOUBLE_PRECISION, MPI_SUM, mg%comm, ierr)
      end if
    else if (c%a%ye >= c%a%ys) then
      call strip_sums_ac(mg%comm, c%below, c%above, c%a%r, c%a%ys, c%a%ye, c%h, c%ac, c%acbuf)
    end if
  end subroutine finish_sums_ac

  !> The restriction sums of level c (in c%w) completed as in finish_sums_ac,
  !> into c%rhs.
  subroutine finish_sums_w(mg, c)
    type(stencil_mg_t), intent(inout) :: mg
    type(mg_level_t), intent(inout) :: c
    integer :: ierr
    if (c%replicated) then
      c%rhs = c%w(0:c%a%nx - 1, :, c%a%ys:c%a%ye)
      if (mg%nranks > 1) call MPI_Allreduce(MPI_IN_PLACE, c%rhs, size(c%rhs), MPI_REAL, MPI_SUM, mg%comm, ierr)
    else if (c%a%ye >= c%a%ys) then
      call strip_sums_w(mg%comm, c%below, c%above, c%a%nx, c%a%ys, c%a%ye, c%h, c%w, c%x, c%rhs)
    end if
  end subroutine finish_sums_w

  !> Fill the ghost rows of a level's x from the neighbouring strips.
  subroutine exchange(mg, lv)
    type(stencil_mg_t), intent(inout) :: mg
    type(mg_level_t), intent(inout) :: lv
    if (lv%replicated .or. mg%nranks == 1 .or. lv%a%ye < lv%a%ys) return
    call strip_exchange(mg%comm, lv%below, lv%above, lv%x, lv%a%ys, lv%a%ye, lv%h)
  end subroutine exchange

  !> Seam sweeps (smooth) on or off, the same on every rank.
  subroutine mg_set_seam(mg, on)
    type(stencil_mg_t), intent(inout) :: mg
    logical, intent(in) :: on
    mg%seam = on
  end subroutine mg_set_seam

  !> One symmetric Gauss-Seidel smoothing (forward, then backward sweep),
  !> the ghost rows exchanged before each: within a strip lexicographic,
  !> between strips block Jacobi, as PETSc's SOR. (Rows coloured by j mod
  !> (r + 1), the same smoother on any number of ranks, took 7 % more
  !> iterations on hang 257 x 257: docs/performance.md.)
  !>
  !> ax (the finest level's last smoothing of a cycle): also ax = A x of
  !> the result, in the arithmetic of the Krylov method's mixed product
  !> (kernel stencil_product_mixed); the backward sweep forms the rows
  !> whose neighbours it has finished on this strip, the first and last r
  !> rows follow after one more exchange. ax(3, 0:nx-1, ys:ye).
  !>
  !> Seam sweeps (mg%seam, several ranks): then, after an exchange, the
  !> first r rows of each strip above another forward once more, so that a
  !> pair coupled across the boundary by a rank-one barrier block (the
  !> faces') is smoothed in turn, not side by side: Jacobi's iteration
  !> leaves its stiff mode near -1 (docs/contact.md, "Faces and edges").
  subroutine smooth(mg, lv, ax)
    type(stencil_mg_t), intent(inout) :: mg
    type(mg_level_t), intent(inout) :: lv
    real(rp), intent(inout), optional :: ax(:, 0:, lv%a%ys:)
    integer :: ys, ye, r, jb
    logical :: seam
    if (lv%a%ye < lv%a%ys) return
    ys = lv%a%ys
    ye = lv%a%ye
    r = lv%a%r
    seam = mg%seam .and. mg%nranks > 1 .and. .not. lv%replicated
    call exchange(mg, lv)
    call gs_sweep(lv%a, lv%h, lv%x, lv%rhs, .true., lv%t, lv%low)
    call exchange(mg, lv)
    if (.not. present(ax)) then
      call gs_sweep(lv%a, lv%h, lv%x, lv%rhs, .false., lv%t, lv%low)
      if (seam) then
        call exchange(mg, lv)
        call seam_sweep(lv)
      end if
      return
    end if
    call gs_sweep(lv%a, lv%h, lv%x, lv%rhs, .false., lv%t, lv%low, mg%pxs, mg%pacc, mg%pds, ax)
    call exchange(mg, lv)
    jb = ys + r - 1                    ! the first rows' products need the neighbours' rows
    if (seam) then
      call seam_sweep(lv)
      call exchange(mg, lv)
      jb = ys + 2 * r - 1
    end if
    call level_product_rows(lv%a, lv%h, lv%x, ys, min(jb, ye), mg%pxs, mg%pacc, mg%pds, ax)
    call level_product_rows(lv%a, lv%h, lv%x, max(ye - r + 1, jb + 1), ye, mg%pxs, mg%pacc, mg%pds, ax)
  end subroutine smooth

  !> Rows ys..ys+r-1 forward where a strip lies below (smooth).
  subroutine seam_sweep(lv)
    type(mg_level_t), intent(inout) :: lv
    if (lv%below == MPI_PROC_NULL) return
    call gs_sweep(lv%a, lv%h, lv%x, lv%rhs, .true., lv%t, rows=[lv%a%ys, min(lv%a%ys + lv%a%r - 1, lv%a%ye)])
  end subroutine seam_sweep

  !> Restrict level l's residual (or, with from_rhs, its right-hand side)
  !> into level l + 1's right-hand side.
  subroutine restrict_level(mg, l, from_rhs)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: l
    logical, intent(in) :: from_rhs
    integer :: k
    associate (f => mg%lev(l), c => mg%lev(l + 1))
      if (gather_on(c%gat)) then
        if (from_rhs) then
          call gather_restrict(c%gat, f%tx, f%ty, f%a%ys, f%a%ye, f%rhs, c%a%ys, c%a%ye, c%w, c%rhs, c%t)
        else
          call gather_restrict(c%gat, f%tx, f%ty, f%a%ys, f%a%ye, f%res, c%a%ys, c%a%ye, c%w, c%rhs, c%t)
        end if
      else
        c%w = 0.0_mp
        if (from_rhs) then
          call restrict_add(f%tx, f%ty, f%a%ys, f%a%ye, f%rhs, c%h, c%a%ys, c%w, c%t)
        else
          call restrict_add(f%tx, f%ty, f%a%ys, f%a%ye, f%res, c%h, c%a%ys, c%w, c%t)
        end if
        call finish_sums_w(mg, c)
      end if
      if (allocated(c%fixed)) then
        do k = 1, size(c%fixed, 2)
          c%rhs(c%fixed(1, k), :, c%fixed(2, k)) = 0.0_mp
        end do
      end if
    end associate
  end subroutine restrict_level

  !> The coarsest level: x = A^{-1} rhs by the banded LU, on every rank.
  subroutine coarse_solve(mg)
    type(stencil_mg_t), intent(inout) :: mg
    integer :: i, j, c1, info
    associate (c => mg%lev(mg%nlev))
      do j = 0, c%a%ny - 1
        do c1 = 1, 3
          do i = 0, c%a%nx - 1
            mg%xc(3 * (i + c%a%nx * j) + c1) = real(c%rhs(i, c1, j), rp)
          end do
        end do
      end do
      call dgbtrs('N', mg%n, mg%kl, mg%kl, 1, mg%ab, 3 * mg%kl + 1, mg%ipiv, mg%xc, mg%n, info)
      do j = 0, c%a%ny - 1
        do c1 = 1, 3
          do i = 0, c%a%nx - 1
            c%x(i, c1, j) = real(mg%xc(3 * (i + c%a%nx * j) + c1), mp)
          end do
        end do
      end do
    end associate
  end subroutine coarse_solve

  !> One V-cycle on level l and below, x from zero (from_zero absent or
  !> true) or from the x there (a W-cycle's second visit); gamma cycles
  !> on the next level (1: V, 2: W).
  recursive subroutine vcycle(mg, l, ax, from_zero)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: l
    real(rp), intent(inout), optional :: ax(:, 0:, mg%lev(1)%a%ys:)   !< (3, 0:nx-1, ys:ye) A x of the result (smooth)
    logical, intent(in), optional :: from_zero
    integer :: k
    if (l == mg%nlev) then
      call coarse_solve(mg)
      return
    end if
    associate (f => mg%lev(l))
      if (.not. present(from_zero)) then
        f%x = 0.0_mp
      else if (from_zero) then
        f%x = 0.0_mp
      end if
      do k = 1, mg%nu
        call smooth(mg, f)
      end do
      call exchange(mg, f)
      if (f%a%ye >= f%a%ys) call residual(f%a, f%h, f%x, f%rhs, f%res)
      call restrict_level(mg, l, .false.)
      call vcycle(mg, l + 1)
      if (mg%gamma > 1 .and. l + 1 < mg%nlev) call vcycle(mg, l + 1, from_zero=.false.)
    end associate
    call correct_and_smooth(mg, l, .true., ax)
  end subroutine vcycle

  !> Kaskade: rhs restricted to the coarsest level, solved, then up level by
  !> level: interpolated, smoothed, never back down.
  subroutine kcycle(mg, ax)
    type(stencil_mg_t), intent(inout) :: mg
    real(rp), intent(inout), optional :: ax(:, 0:, mg%lev(1)%a%ys:)   !< (3, 0:nx-1, ys:ye) A x of the result (smooth)
    integer :: l
    do l = 1, mg%nlev - 1
      call restrict_level(mg, l, .true.)
    end do
    call coarse_solve(mg)
    do l = mg%nlev - 1, 1, -1
      call correct_and_smooth(mg, l, .false., ax)
    end do
  end subroutine kcycle

  !> Level l's x from level l + 1's, interpolated (added to x: the V-cycle's
  !> correction; or x itself: kaskade), then nu symmetric sweeps on level l,
  !> the last of which forms A x (ax) on the finest level when asked.
  subroutine correct_and_smooth(mg, l, add, ax)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: l
    logical, intent(in) :: add
    real(rp), intent(inout), optional :: ax(:, 0:, mg%lev(1)%a%ys:)   !< (3, 0:nx-1, ys:ye) A x of the result (smooth)
    integer :: k
    associate (f => mg%lev(l), c => mg%lev(l + 1))
      if (gather_on(c%gat)) then
        call gather_interpolate(c%gat, f%ux, f%uy, c%a%ys, c%x, f%a%ys, f%a%ye, f%h, f%x, add, c%t)
      else
        if (f%a%ye < f%a%ys) return
        call exchange(mg, c)
        call interpolate(f%ux, f%uy, f%a%ys, f%a%ye, c%h, c%a%ys, c%x, f%h, f%x, add, c%t)
      end if
      do k = 1, mg%nu - 1
        call smooth(mg, f)
      end do
      if (l == 1 .and. present(ax)) then
        call smooth(mg, f, ax)
      else
        call smooth(mg, f)
      end if
    end associate
  end subroutine correct_and_smooth

  !> x = M^{-1} b, one cycle: b(3, 0:nx-1, ys:ye), x likewise (the layout
  !> of a 3-dof DMDA vector). With ax: also ax = A x, formed in the
  !> finest level's last sweep (smooth), exactly as stencil_product_mixed
  !> forms it from x (the Krylov method's next product is of x: module
  !> reduced keeps this one for it); formed = .false. where there is no
  !> sweep on the finest level (a hierarchy of one level). Collective.
  subroutine mg_apply(mg, b, x, ax, formed)
    type(stencil_mg_t), intent(inout) :: mg
    real(rp), intent(in) :: b(:, 0:, mg%lev(1)%a%ys:)
    real(rp), intent(out) :: x(:, 0:, mg%lev(1)%a%ys:)
    real(rp), intent(inout), optional :: ax(:, 0:, mg%lev(1)%a%ys:)
    logical, intent(out), optional :: formed
    integer :: i, j, c
    associate (f => mg%lev(1))
      do j = f%a%ys, f%a%ye
        do c = 1, 3
          do i = 0, f%a%nx - 1
            f%rhs(i, c, j) = real(b(c, i, j), mp)
          end do
        end do
      end do
      if (present(formed)) formed = present(ax) .and. mg%nlev > 1
      if (mg%nlev == 1) then
        call coarse_solve(mg)
      else if (mg%cycle_type == CYCLE_KASKADE) then
        call kcycle(mg, ax)
      else
        call vcycle(mg, 1, ax)
      end if
      do j = f%a%ys, f%a%ye
        do i = 0, f%a%nx - 1
          do c = 1, 3
            x(c, i, j) = real(f%x(i, c, j), rp)
          end do
        end do
      end do
    end associate
  end subroutine mg_apply

  !> y = A x with the finest level's operator (kernel stencil_product_mixed:
  !> double-precision vectors, single-precision blocks in difference form).
  !> x(3, 0:nx-1, gys:gye), the rows ys - r .. ye + r that lie in the
  !> lattice, exchanged by the caller; y(3, 0:nx-1, ys:ye).
  subroutine mg_product(mg, gys, gye, x, y)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: gys, gye
    real(rp), intent(in), contiguous :: x(:)
    real(rp), intent(out), contiguous :: y(:)
    call stencil_product_mixed(mg%lev(1)%a, gys, gye, x, y, mg%pxs, mg%pacc, mg%pds)
  end subroutine mg_product

end module stencil_mg
