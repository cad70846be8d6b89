! SPDX-License-Identifier: BSD-2-Clause
!> The transfers between the levels of nuno's structured multigrid (module
!> stencil_mg) and its Galerkin coarse operator P^T A P. Plain arrays; no
!> PETSc, no MPI (tests/unit/test_mg_kernels.f90 through module mg_kernels).
!>
!> Transfers are tensor products of 1-D weights (bilinear, or the cubic
!> ones of module interpolation), fine point f of nf from coarse points of
!> nc = (nf - 1)/2 + 1.
module mg_transfer
  use kinds, only: rp
  use interpolation, only: cubic_weights
  use mg_stencil, only: mp, stencil_t
  implicit none
  private
  public :: transfer_t, transfer_init, coarse_reach, interpolate, restrict_add, galerkin_add

  !> 1-D transfer: fine point f takes w(1:n(f), f) of coarse points c(1:n(f), f).
  type :: transfer_t
    integer :: nf = 0, nc = 0
    integer, allocatable :: n(:)                 !< (0:nf-1)
    integer, allocatable :: c(:, :)              !< (4, 0:nf-1) 0-based coarse indices
    real(rp), allocatable :: w(:, :)             !< (4, 0:nf-1)
    !> The regular interior (found by transfer_init, used by interpolate and
    !> restrict_add along x in vector loops): every even fine point 2k is
    !> coarse point k (inject), and the odd fine points 2k + 1, k = klo..khi,
    !> take the same nodd (2 or 4) weights wodd of coarse points k + sodd ..
    !> k + sodd + nodd - 1; the other fine points, ends(:), point by point
    !> through the index arrays (every point when not inject). Point by
    !> point everywhere, these loops were 5 % of a step.
    logical :: inject = .false.
    integer :: klo = 0, khi = -1, nodd = 0, sodd = 0
    real(mp) :: wodd(4) = 0.0_mp
    integer, allocatable :: ends(:)
  end type transfer_t

contains

  !> 1-D weights from nc = (nf - 1)/2 + 1 coarse points to nf fine ones:
  !> bilinear, or cubic (module interpolation).
  subroutine transfer_init(tr, nf, cubic)
    type(transfer_t), intent(inout) :: tr
    integer, intent(in) :: nf
    logical, intent(in) :: cubic
    integer :: f, ix(4), n
    real(rp) :: w(4)
    tr%nf = nf
    tr%nc = (nf - 1) / 2 + 1
    if (allocated(tr%n)) deallocate(tr%n, tr%c, tr%w, tr%ends)
    allocate(tr%n(0:nf - 1), tr%c(4, 0:nf - 1), tr%w(4, 0:nf - 1))
    tr%c = 0
    tr%w = 0.0_rp
    do f = 0, nf - 1
      if (cubic) then
        call cubic_weights(f, tr%nc, ix, w, n)
      else if (mod(f, 2) == 0) then
        n = 1
        ix(1) = f / 2
        w(1) = 1.0_rp
      else
        n = 2
        ix(1:2) = [(f - 1) / 2, (f + 1) / 2]
        w(1:2) = 0.5_rp
      end if
      tr%n(f) = n
      tr%c(1:n, f) = ix(1:n)
      tr%w(1:n, f) = w(1:n)
    end do
    call find_regular(tr)
  end subroutine transfer_init

  !> The regular interior of a transfer (transfer_t): the odd fine points
  !> around the middle one with its weights, as far as they reach; the
  !> rest, in increasing order, its ends.
  subroutine find_regular(tr)
    type(transfer_t), intent(inout) :: tr
    integer :: f, k, km
    tr%inject = .true.
    do f = 0, tr%nf - 1, 2
      if (tr%n(f) /= 1 .or. tr%c(1, f) /= f / 2 .or. tr%w(1, f) /= 1.0_rp) tr%inject = .false.
    end do
    tr%klo = 0
    tr%khi = -1
    if (.not. tr%inject) then
      tr%ends = [(f, f = 0, tr%nf - 1)]
      return
    end if
    km = (tr%nf - 1) / 4                 ! the middle odd point, 2 km + 1
    if (tr%nf >= 3) then
      tr%nodd = tr%n(2 * km + 1)
      tr%sodd = tr%c(1, 2 * km + 1) - km
      tr%wodd = 0.0_mp
      tr%wodd(1:tr%nodd) = real(tr%w(1:tr%nodd, 2 * km + 1), mp)
    end if
    ! (interpolate_x's vector loops take 2 or 4 parents)
    if (tr%nf >= 3 .and. (tr%nodd == 2 .or. tr%nodd == 4)) then
      tr%klo = km
      tr%khi = km
      do while (tr%klo > 0)
        if (.not. regular(tr%klo - 1)) exit
        tr%klo = tr%klo - 1
      end do
      do while (2 * (tr%khi + 1) + 1 <= tr%nf - 1)
        if (.not. regular(tr%khi + 1)) exit
        tr%khi = tr%khi + 1
      end do
    end if
    tr%ends = [(2 * k + 1, k = 0, tr%klo - 1), (2 * k + 1, k = tr%khi + 1, (tr%nf - 2) / 2)]
  contains
    logical function regular(k)
      integer, intent(in) :: k
      integer :: a
      regular = tr%n(2 * k + 1) == tr%nodd
      if (.not. regular) return
      do a = 1, tr%nodd
        regular = regular .and. tr%c(a, 2 * k + 1) == k + tr%sodd + a - 1 &
                  .and. real(tr%w(a, 2 * k + 1), mp) == tr%wodd(a)
      end do
    end function regular
  end subroutine find_regular

  !> Reach of the Galerkin operator P^T A P along one direction, for an A
  !> of reach r: the largest |I - J| with I a parent of f1, J of f2,
  !> |f1 - f2| <= r (one-sided cubic weights at the ends included).
  pure integer function coarse_reach(tr, r) result(rc)
    type(transfer_t), intent(in) :: tr
    integer, intent(in) :: r
    integer :: f1, f2, a, b
    rc = 0
    do f1 = 0, tr%nf - 1
      do f2 = max(0, f1 - r), min(tr%nf - 1, f1 + r)
        do a = 1, tr%n(f1)
          do b = 1, tr%n(f2)
            rc = max(rc, abs(tr%c(a, f1) - tr%c(b, f2)))
          end do
        end do
      end do
    end do
  end function coarse_reach

  !> xf = P xc (add: xf = xf + P xc) on fine rows ysf..yef. xc holds every
  !> coarse row that those rows need (its own padding hc). t(0:nxc-1, 3): work.
  subroutine interpolate(tx, ty, ysf, yef, hc, ysc, xc, hf, xf, add, t)
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: ysf, yef, hc, ysc, hf
    real(mp), intent(in) :: xc(-hc:, :, ysc - hc:)
    real(mp), intent(inout) :: xf(-hf:, :, ysf - hf:)
    logical, intent(in) :: add
    real(mp), intent(inout) :: t(0:, :)
    integer :: j, b, c, nxc
    nxc = tx%nc
    do j = ysf, yef
      t = 0.0_mp
      do b = 1, ty%n(j)
        t = t + real(ty%w(b, j), mp) * xc(0:nxc - 1, :, ty%c(b, j))
      end do
      if (.not. add) xf(0:tx%nf - 1, :, j) = 0.0_mp
      do c = 1, 3
        call interpolate_x(tx, tx%nf, tx%nc, t(:, c), xf(0:tx%nf - 1, c, j))
      end do
    end do
  end subroutine interpolate

  !> xf = xf + P_x t along one fine row (one component): the regular
  !> interior in vector loops (transfer_t), the rest point by point; the
  !> same sums in the same order either way.
  subroutine interpolate_x(tr, nf, nc, t, xf)
    type(transfer_t), intent(in) :: tr
    integer, intent(in) :: nf, nc
    real(mp), intent(in) :: t(0:nc - 1)
    real(mp), intent(inout) :: xf(0:nf - 1)
    integer :: m, k, s
    real(mp) :: w1, w2, w3, w4
    do m = 1, size(tr%ends)
      call point(tr%ends(m))
    end do
    if (.not. tr%inject) return
    do k = 0, (nf - 1) / 2
      xf(2 * k) = xf(2 * k) + t(k)
    end do
    s = tr%sodd
    w1 = tr%wodd(1)
    w2 = tr%wodd(2)
    w3 = tr%wodd(3)
    w4 = tr%wodd(4)
    select case (tr%nodd)
    case (2)
      do k = tr%klo, tr%khi
        xf(2 * k + 1) = xf(2 * k + 1) + w1 * t(k + s) + w2 * t(k + s + 1)
      end do
    case (4)
      do k = tr%klo, tr%khi
        xf(2 * k + 1) = xf(2 * k + 1) + w1 * t(k + s) + w2 * t(k + s + 1) + w3 * t(k + s + 2) + w4 * t(k + s + 3)
      end do
    end select
  contains
    subroutine point(i)
      integer, intent(in) :: i
      integer :: a
      do a = 1, tr%n(i)
        xf(i) = xf(i) + real(tr%w(a, i), mp) * t(tr%c(a, i))
      end do
    end subroutine point
  end subroutine interpolate_x

  !> t = P_x^T rf along one fine row (one component), as interpolate_x.
  subroutine restrict_x(tr, nf, nc, rf, t)
    type(transfer_t), intent(in) :: tr
    integer, intent(in) :: nf, nc
    real(mp), intent(in) :: rf(0:nf - 1)
    real(mp), intent(out) :: t(0:nc - 1)
    integer :: m, k, a, s
    real(mp) :: wa
    t = 0.0_mp
    do m = 1, size(tr%ends)
      call point(tr%ends(m))
    end do
    if (.not. tr%inject) return
    do k = 0, (nf - 1) / 2
      t(k) = t(k) + rf(2 * k)
    end do
    s = tr%sodd
    do a = 1, tr%nodd
      wa = tr%wodd(a)
      do k = tr%klo, tr%khi
        t(k + s + a - 1) = t(k + s + a - 1) + wa * rf(2 * k + 1)
      end do
    end do
  contains
    subroutine point(i)
      integer, intent(in) :: i
      integer :: a
      do a = 1, tr%n(i)
        t(tr%c(a, i)) = t(tr%c(a, i)) + real(tr%w(a, i), mp) * rf(i)
      end do
    end subroutine point
  end subroutine restrict_x

  !> rc = rc + P^T rf restricted to the contributions of fine rows
  !> ysf..yef; rc is padded (hc) so that it takes the coarse rows of other
  !> ranks too (the caller adds them where they belong). t(0:nxc-1, 3): work.
  subroutine restrict_add(tx, ty, ysf, yef, rf, hc, ysc, rc, t)
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: ysf, yef, hc, ysc
    real(mp), intent(in) :: rf(0:, :, ysf:)
    real(mp), intent(inout) :: rc(-hc:, :, ysc - hc:)
    real(mp), intent(inout) :: t(0:, :)
    integer :: j, b, c, nxc
    nxc = tx%nc
    do j = ysf, yef
      do c = 1, 3
        call restrict_x(tx, tx%nf, nxc, rf(0:tx%nf - 1, c, j), t(0:nxc - 1, c))
      end do
      do b = 1, ty%n(j)
        rc(0:nxc - 1, :, ty%c(b, j)) = rc(0:nxc - 1, :, ty%c(b, j)) + real(ty%w(b, j), mp) * t
      end do
    end do
  end subroutine restrict_add

  !> ac = ac + P^T A P restricted to the contributions of the fine rows
  !> ys..ye of A (full 3 x 3 blocks, double precision): ac(0:nxc-1, 3, 3,
  !> -rc:rc, -rc:rc, jc0:), coarse nodes fastest, with rows for every
  !> coarse row these fine rows touch (the caller adds other ranks' rows
  !> where they belong).
  !> Factored, P = P_y (x) P_x: each fine row j's blocks are first summed
  !> along x into bx(ci, 3, 3, cdi, dj) = sum_{i, i'} P_x(i, ci) A(ij, i'j')
  !> P_x(i', ci + cdi) (dj = j' - j), then bx along y into ac. Each fine
  !> block then takes (parents in x)^2 updates and each bx block (parents
  !> in y)^2, where the direct sum took their product: 16 against 4 + 4
  !> (bilinear), 256 against 16 + 16 (cubic), at worst. Nodes fastest
  !> everywhere, as the levels keep their blocks: the fine blocks are
  !> converted in vector loops, with bilinear transfers the sums along x
  !> are vector loops over the coarse nodes (galerkin_x_bilinear), the sums
  !> along y one vector loop over a coarse row, and stencil_finish makes
  !> the level from its sums in vector loops (node by node, with a block's
  !> nine entries together, these took 4-5 times as long: hang 257 x 257).
  subroutine galerkin_add(st, tx, ty, rc, jc0, ac, bx, rw)
    type(stencil_t), intent(in) :: st
    type(transfer_t), intent(in) :: tx, ty
    integer, intent(in) :: rc, jc0
    real(rp), intent(inout), contiguous :: ac(0:, :, :, -rc:, -rc:, jc0:)
    real(rp), intent(inout), contiguous :: bx(0:, :, :, -rc:, -st%r:)  !< (0:nxc-1, 3, 3, -rc:rc, -r:r) work
    !> (0:nx-1, 3, 3, 2) work: a fine row's diagonal blocks D_p - sum_o B_{p,o}
    !> (dg) and its blocks of one offset (blk), in double precision
    real(rp), intent(inout), contiguous, target :: rw(0:, :, :, :)
    real(rp), pointer, contiguous :: dg(:, :), blk(:, :)
    integer :: j, k, di, dj, j2, b1, b2, cj, cdj, ilo, ihi, cilo, cihi, m
    logical :: bilinear
    dg(0:st%nx - 1, 1:9) => rw(:, :, :, 1)
    blk(0:st%nx - 1, 1:9) => rw(:, :, :, 2)
    ! bilinear along x: every odd fine point 2k + 1 takes 1/2 of coarse
    ! points k and k + 1 (transfer_init without cubic; find_regular found
    ! its interior regular), so coarse point ci has exactly the fine
    ! children 2 ci - 1, 2 ci and 2 ci + 1
    bilinear = tx%inject .and. tx%nodd == 2 .and. tx%sodd == 0 .and. size(tx%ends) == 0
    if (bilinear) bilinear = all(tx%wodd(1:2) == 0.5_mp)
    do j = st%ys, st%ye
      bx = 0.0_rp
      call row_sums_double(st%nx, st%d(:, :, :, j), dg)
      ! offset by offset along the row, the diagonal blocks last
      do k = 1, st%nb + 1
        if (k <= st%nb) then
          di = st%odi(k)
          dj = st%odj(k)
        else
          di = 0
          dj = 0
        end if
        j2 = j + dj
        if (j2 < 0 .or. j2 >= st%ny) cycle
        ilo = max(0, -di)
        ihi = min(st%nx - 1, st%nx - 1 - di)
        if (k > st%nb) then
          blk = dg
        else if (dj == 0) then
          call blocks_within_row(st%nx, st%nr, ilo, ihi, st%slot(k), st%br(:, :, :, :, j), blk, dg)
        else
          call blocks_to_row(st%nx, ilo, ihi, st%b(:, :, :, st%slot(k), j), blk, dg)
        end if
        ! the coarse nodes cilo..cihi whose fine children (2 ci - 1, 2 ci,
        ! 2 ci + 1 with weights 1/2, 1, 1/2) and their neighbours at di
        ! lie inside the row and the regular interior (bilinear
        ! transfers); the others through the general transfer
        cilo = 1
        cihi = 0
        if (bilinear) then
          m = min(ihi, 2 * tx%nc - 2, 2 * tx%nc - 2 - di)
          cilo = (ilo + 2) / 2
          cihi = cilo - 1
          if (m >= 1) cihi = (m - 1) / 2
        end if
        if (cilo <= cihi) then
          call galerkin_x_bilinear(st%nx, tx%nc, rc, st%r, cilo, cihi, di, dj, blk, bx)
          call galerkin_x(st%nx, tx%nc, rc, st%r, size(tx%c, 1), ilo, min(ihi, 2 * cilo - 1), di, dj, &
                          tx%n, tx%c, tx%w, blk, bx, cilo, cihi)
          call galerkin_x(st%nx, tx%nc, rc, st%r, size(tx%c, 1), max(ilo, 2 * cihi + 1), ihi, di, dj, &
                          tx%n, tx%c, tx%w, blk, bx, cilo, cihi)
        else
          call galerkin_x(st%nx, tx%nc, rc, st%r, size(tx%c, 1), ilo, ihi, di, dj, tx%n, tx%c, tx%w, blk, bx, 1, 0)
        end if
      end do
      do dj = -st%r, st%r
        j2 = j + dj
        if (j2 < 0 .or. j2 >= st%ny) cycle
        do b1 = 1, ty%n(j)
          cj = ty%c(b1, j)
          do b2 = 1, ty%n(j2)
            cdj = ty%c(b2, j2) - cj
            call galerkin_y(9 * (2 * rc + 1) * tx%nc, rc, st%r, dj, cdj, ty%w(b1, j) * ty%w(b2, j2), bx, &
                            ac(:, :, :, :, :, cj))
          end do
        end do
      end do
    end do
  end subroutine galerkin_add

  !> galerkin_add's sum along x of one offset (di, dj) of a fine row:
  !> bx(ci, :, cdi, dj) += P_x(i, ci) P_x(i + di, ci + cdi) blk(i, :) for
  !> i = ilo..ihi and their parents (n(i) of them, c(:, i), weights w(:, i)),
  !> but not for the coarse points xlo..xhi (galerkin_x_bilinear's).
  !> Explicit shapes (over the derived types' components, every update
  !> reloaded their descriptors: most of the coarse operators' set-up).
  pure subroutine galerkin_x(nx, nxc, rc, r, nmax, ilo, ihi, di, dj, n, c, w, blk, bx, xlo, xhi)
    integer, intent(in) :: nx, nxc, rc, r, nmax, ilo, ihi, di, dj, xlo, xhi
    integer, intent(in) :: n(0:nx - 1), c(nmax, 0:nx - 1)
    real(rp), intent(in) :: w(nmax, 0:nx - 1)
    real(rp), intent(in) :: blk(0:nx - 1, 9)
    real(rp), intent(inout) :: bx(0:nxc - 1, 9, -rc:rc, -r:r)
    integer :: i, i2, a1, a2, ci, cdi
    real(rp) :: wx, ww
    do i = ilo, ihi
      if (all(blk(i, :) == 0.0_rp)) cycle
      i2 = i + di
      do a1 = 1, n(i)
        ci = c(a1, i)
        if (ci >= xlo .and. ci <= xhi) cycle
        wx = w(a1, i)
        do a2 = 1, n(i2)
          cdi = c(a2, i2) - ci
          ww = wx * w(a2, i2)
          bx(ci, :, cdi, dj) = bx(ci, :, cdi, dj) + ww * blk(i, :)
        end do
      end do
    end do
  end subroutine galerkin_x

  !> galerkin_x for bilinear transfers, coarse points cilo..cihi, summed by
  !> coarse point in vector loops: bx(ci, :, cdi, dj) += sum_s wt(cdi, s)
  !> blk(2 ci + s, :), s = -1, 0, 1 (the children of ci, weights 1/2, 1,
  !> 1/2, each times the weight of coarse point ci + cdi in fine point
  !> 2 ci + s + di).
  pure subroutine galerkin_x_bilinear(nx, nxc, rc, r, cilo, cihi, di, dj, blk, bx)
    integer, intent(in) :: nx, nxc, rc, r, cilo, cihi, di, dj
    real(rp), intent(in) :: blk(0:nx - 1, 9)
    real(rp), intent(inout) :: bx(0:nxc - 1, 9, -rc:rc, -r:r)
    real(rp) :: wt(-rc:rc, -1:1), wa, w1, w0, w2
    integer :: s, t, ci, cdi, e
    wt = 0.0_rp
    do s = -1, 1
      wa = merge(1.0_rp, 0.5_rp, s == 0)
      t = s + di                                ! fine point 2 ci + t
      if (modulo(t, 2) == 0) then
        wt(t / 2, s) = wt(t / 2, s) + wa
      else
        wt((t - 1) / 2, s) = wt((t - 1) / 2, s) + 0.5_rp * wa
        wt((t + 1) / 2, s) = wt((t + 1) / 2, s) + 0.5_rp * wa
      end if
    end do
    do cdi = -rc, rc
      w1 = wt(cdi, -1)
      w0 = wt(cdi, 0)
      w2 = wt(cdi, 1)
      if (w1 == 0.0_rp .and. w0 == 0.0_rp .and. w2 == 0.0_rp) cycle
      do e = 1, 9
        do ci = cilo, cihi
          bx(ci, e, cdi, dj) = bx(ci, e, cdi, dj) + (w1 * blk(2 * ci - 1, e) + w0 * blk(2 * ci, e) + w2 * blk(2 * ci + 1, e))
        end do
      end do
    end do
  end subroutine galerkin_x_bilinear

  !> galerkin_add's diagonal blocks of a fine row start as its row sums
  !> d (single precision) in double precision.
  pure subroutine row_sums_double(nx, d, dg)
    integer, intent(in) :: nx
    real(mp), intent(in) :: d(0:nx - 1, 9)
    real(rp), intent(out) :: dg(0:nx - 1, 9)
    dg = real(d, rp)
  end subroutine row_sums_double

  !> galerkin_add's blocks of one offset to another row (b of row j,
  !> single precision) into blk(i, :), i = ilo..ihi, in double precision,
  !> and subtracted from the diagonal blocks dg.
  pure subroutine blocks_to_row(nx, ilo, ihi, b, blk, dg)
    integer, intent(in) :: nx, ilo, ihi
    real(mp), intent(in) :: b(0:nx - 1, 9)
    real(rp), intent(inout) :: blk(0:nx - 1, 9), dg(0:nx - 1, 9)
    integer :: e
    do e = 1, 9
      blk(ilo:ihi, e) = real(b(ilo:ihi, e), rp)
      dg(ilo:ihi, e) = dg(ilo:ihi, e) - blk(ilo:ihi, e)
    end do
  end subroutine blocks_to_row

  !> As blocks_to_row for the blocks of offset sl within the row (br of
  !> row j, node by node).
  pure subroutine blocks_within_row(nx, nr, ilo, ihi, sl, br, blk, dg)
    integer, intent(in) :: nx, nr, ilo, ihi, sl
    real(mp), intent(in) :: br(9, nr, 0:nx - 1)
    real(rp), intent(inout) :: blk(0:nx - 1, 9), dg(0:nx - 1, 9)
    integer :: i, e
    do e = 1, 9
      do i = ilo, ihi
        blk(i, e) = real(br(e, sl, i), rp)
        dg(i, e) = dg(i, e) - blk(i, e)
      end do
    end do
  end subroutine blocks_within_row

  !> galerkin_add's sum along y: coarse row cj's sums at offset cdj take
  !> wy times the fine row's sums along x at offset dj (n values: every
  !> coarse node's blocks of every cdi), one vector loop.
  pure subroutine galerkin_y(n, rc, r, dj, cdj, wy, bx, acj)
    integer, intent(in) :: n, rc, r, dj, cdj
    real(rp), intent(in) :: wy
    real(rp), intent(in) :: bx(n, -r:r)
    real(rp), intent(inout) :: acj(n, -rc:rc)
    acj(:, cdj) = acj(:, cdj) + wy * bx(:, dj)
  end subroutine galerkin_y

end module mg_transfer
