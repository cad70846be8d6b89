! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the structured multigrid's kernels (module mg_kernels)
!> against dense matrices built independently from the same blocks:
!>  - the difference form reproduces A x (random blocks, zero row sums plus
!>    a mass-like diagonal, 11 x 9 lattice, reach 2);
!>  - restriction is the transpose of interpolation (bilinear and cubic);
!>  - galerkin_add + stencil_finish give the dense P^T A P (both transfers,
!>    reach 1 and 2), including the coarse reach coarse_reach predicts;
!>  - symmetric Gauss-Seidel sweeps converge to the dense solution of a
!>    diagonally dominant system, forward and backward alike, also with
!>    the sums over the rows below kept between the two sweeps;
!>  - with contact's node blocks (kappa n n^T on a third of the nodes'
!>    diagonal, kappa 1e4 times the links' stiffness, n a random unit
!>    normal: the barrier's df/dx) the Galerkin product still equals the
!>    dense P^T A P, so the coarse levels carry them, and the symmetric
!>    block Gauss-Seidel sweeps converge as fast as without them (each
!>    node's 3 x 3 block inverted whole; a pointwise smoother would need
!>    about kappa/mass sweeps to resolve the stiff normal);
!>  - the row sums survive single precision: for a stiff operator
!>    (stiffness 1e6 times the mass) applied to a constant vector the stored
!>    operator gives the mass term to single-precision accuracy, where
!>    rounding the full blocks would not;
!>  - a paired operator (A(p, p + o) = A(p + o, p): S without bending)
!>    gives the same sweeps and products, bit for bit, with the kernels
!>    taking the blocks to the rows below from those rows (stencil_t's
!>    paired) as from its own rows, on strips; an unpaired one does not
!>    (so the paired path is the one taken).
program test_mg_kernels
  use kinds, only: rp
  use mg_kernels, only: mp, stencil_t, transfer_t, stencil_init, stencil_put_row, stencil_finish, transfer_init, &
                        coarse_reach, coupled_by_elements, stencil_block, offset_index, gs_sweep, residual, stencil_apply, interpolate, restrict_add, galerkin_add, &
                        stencil_from_full, stencil_product_mixed, level_product_rows
  use offset_product, only: stencil_product, offset_count, offset_slot
  use check, only: check_true, check_close, check_report
  use, intrinsic :: iso_c_binding, only: c_long
  implicit none
  interface
    !> malloc calls since the start (tests/unit/malloc_count.c)
    integer(c_long) function malloc_calls() bind(C, name='nuno_test_malloc_calls')
      import :: c_long
    end function malloc_calls
  end interface

  call test_apply(2)
  call test_apply(1)
  call test_transpose(.false.)
  call test_transpose(.true.)
  call test_transfer_reference(33, 17, .false.)
  call test_transfer_reference(33, 17, .true.)
  call test_transfer_reference(7, 5, .true.)
  call test_transfer_reference(5, 3, .true.)
  call test_galerkin(1, .false.)
  call test_galerkin(2, .false.)
  call test_galerkin(2, .true.)
  call test_galerkin(2, .false., lines=.true.)
  call test_galerkin(1, .false., nodal=1.0e4_rp)
  call test_galerkin(2, .true., nodal=1.0e4_rp)
  call test_smoother(1, 9)
  call test_smoother(2, 9)
  call test_smoother(3, 9)
  ! rows longer than a 512-bit vector of kind mp (16), with a remainder
  call test_smoother(1, 37)
  call test_smoother(2, 37)
  call test_smoother(3, 37)
  call test_smoother(1, 9, nodal=1.0e4_rp)
  call test_smoother(2, 37, nodal=1.0e4_rp)
  call test_row_sums()
  call test_from_full(1)
  call test_from_full(2)
  call test_product_mixed(1, 0, 8, 11)
  call test_product_mixed(2, 0, 8, 11)
  call test_product_mixed(2, 3, 5, 11)
  call test_product_mixed(1, 2, 6, 11)
  call test_product_mixed(2, 0, 8, 37)
  call test_product_mixed(1, 2, 6, 32)
  call test_fused_product(1, 0, 8, 11)
  call test_fused_product(2, 0, 8, 11)
  call test_fused_product(2, 2, 8, 37)
  call test_fused_product(1, 3, 6, 11)
  call test_fused_product(2, 3, 5, 11)
  call test_fused_product(2, 0, 3, 11)
  call test_paired(1, 0, 8, 11)
  call test_paired(1, 3, 6, 37)
  call test_paired(2, 2, 8, 11)
  call test_paired(2, 0, 5, 37)
  call check_report()

contains

  !> Dense index of (node i, j; component c) on an nx x ny lattice.
  pure integer function gidx(nx, i, j, c)
    integer, intent(in) :: nx, i, j, c
    gidx = 3 * (i + nx * j) + c
  end function gidx

  !> A random operator of reach r on nx x ny: blocks of every link inside the
  !> lattice with zero row sums, plus mass m I on the diagonal; returned as
  !> the stored stencil and the dense matrix.
  subroutine random_operator(nx, ny, r, mass, stiff, st, dense, lines, nodal)
    integer, intent(in) :: nx, ny, r
    real(rp), intent(in) :: mass, stiff
    type(stencil_t), intent(out) :: st
    real(rp), allocatable, intent(out) :: dense(:, :)
    logical, intent(in), optional :: lines    !< only the offsets the cloth's elements couple
    !> contact's node blocks: nodal n n^T (n a random unit normal) added to
    !> the diagonal block of every third node (i + 2 j mod 3 = 0), as the
    !> barrier's -K_c/a enters S's row sums D
    real(rp), intent(in), optional :: nodal
    real(rp) :: blk(3, 3, -r:r, -r:r), rnd(3, 3), blk1(3, 3), nrm(3)
    integer :: i, j, di, dj, c1, c2
    logical :: only_lines
    only_lines = .false.
    if (present(lines)) only_lines = lines
    call stencil_init(st, nx, ny, 0, ny - 1, r, lines=only_lines)
    allocate(dense(3 * nx * ny, 3 * nx * ny))
    dense = 0.0_rp
    do j = 0, ny - 1
      do i = 0, nx - 1
        blk = 0.0_rp
        do dj = -r, r
          do di = -r, r
            if (di == 0 .and. dj == 0) cycle
            if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) cycle
            if (only_lines .and. .not. coupled_by_elements(di, dj)) cycle
            call random_number(rnd)
            blk(:, :, di, dj) = -stiff * (0.5_rp + rnd)
            blk(:, :, 0, 0) = blk(:, :, 0, 0) - blk(:, :, di, dj)
          end do
        end do
        do c1 = 1, 3
          blk(c1, c1, 0, 0) = blk(c1, c1, 0, 0) + mass
        end do
        if (present(nodal)) then
          if (mod(i + 2 * j, 3) == 0) then
            call random_number(nrm)
            nrm = nrm - 0.5_rp
            nrm = nrm / norm2(nrm)
            do c2 = 1, 3
              blk(:, c2, 0, 0) = blk(:, c2, 0, 0) + nodal * nrm * nrm(c2)
            end do
          end if
        end if
        call stencil_put_row(st, i, j, blk)
        ! The dense matrix from the stored (rounded) off-diagonal blocks, so
        ! that only the arithmetic of the kernels is compared.
        do dj = -r, r
          do di = -r, r
            if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) cycle
            do c2 = 1, 3
              do c1 = 1, 3
                if (di == 0 .and. dj == 0) cycle
                if (offset_index(st, di, dj) == 0) cycle
                blk1 = stencil_block(st, i, j, offset_index(st, di, dj))
                dense(gidx(nx, i, j, c1), gidx(nx, i + di, j + dj, c2)) = blk1(c1, c2)
              end do
            end do
          end do
        end do
        do c2 = 1, 3
          do c1 = 1, 3
            dense(gidx(nx, i, j, c1), gidx(nx, i, j, c2)) = real(st%d(i, c1, c2, j), rp)
          end do
        end do
      end do
    end do
    ! diagonal blocks = D - sum of the row's stored off-diagonal blocks
    do j = 0, ny - 1
      do i = 0, nx - 1
        do dj = -r, r
          do di = -r, r
            if (di == 0 .and. dj == 0) cycle
            if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) cycle
            do c2 = 1, 3
              do c1 = 1, 3
                dense(gidx(nx, i, j, c1), gidx(nx, i, j, c2)) = dense(gidx(nx, i, j, c1), gidx(nx, i, j, c2)) &
                  - dense(gidx(nx, i, j, c1), gidx(nx, i + di, j + dj, c2))
              end do
            end do
          end do
        end do
      end do
    end do
  end subroutine random_operator

  !> Padded vector (h) from a dense one.
  subroutine to_padded(nx, ny, h, v, x)
    integer, intent(in) :: nx, ny, h
    real(rp), intent(in) :: v(:)
    real(mp), intent(out) :: x(-h:, :, -h:)
    integer :: i, j, c
    x = 0.0_mp
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          x(i, c, j) = real(v(gidx(nx, i, j, c)), mp)
        end do
      end do
    end do
  end subroutine to_padded

  subroutine test_apply(r)
    integer, intent(in) :: r
    integer, parameter :: nx = 11, ny = 9
    type(stencil_t) :: st
    real(rp), allocatable :: dense(:, :), v(:), av(:)
    real(mp) :: x(-r:nx - 1 + r, 3, -r:ny - 1 + r), y(0:nx - 1, 3, 0:ny - 1)
    real(rp) :: err, scale
    integer :: i, j, c
    character(len=64) :: label
    call random_operator(nx, ny, r, 1.0_rp, 1.0_rp, st, dense)
    allocate(v(3 * nx * ny))
    call random_number(v)
    call to_padded(nx, ny, r, v, x)
    v = [(((real(x(i, c, j), rp), c = 1, 3), i = 0, nx - 1), j = 0, ny - 1)]
    av = matmul(dense, v)
    call stencil_apply(st, r, x, y)
    err = 0.0_rp
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          err = max(err, abs(real(y(i, c, j), rp) - av(gidx(nx, i, j, c))))
        end do
      end do
    end do
    scale = maxval(abs(av))
    write(label, '(a, i0)') 'difference form applies A, reach ', r
    call check_close(err, 0.0_rp, 0.0_rp, 1.0e-5_rp * scale, trim(label))
  end subroutine test_apply

  subroutine test_transpose(cubic)
    logical, intent(in) :: cubic
    integer, parameter :: nxf = 17, nyf = 13, h = 3
    type(transfer_t) :: tx, ty
    real(mp) :: xc(-h:8 + h, 3, -h:6 + h), xf(-h:nxf - 1 + h, 3, -h:nyf - 1 + h), rf(0:nxf - 1, 3, 0:nyf - 1)
    real(mp) :: rc(-h:8 + h, 3, -h:6 + h), t(0:8, 3)
    real(rp) :: lhs, rhs
    call transfer_init(tx, nxf, cubic)
    call transfer_init(ty, nyf, cubic)
    call check_true(tx%nc == 9 .and. ty%nc == 7, 'coarse sizes')
    xc = 0.0_mp
    call random_number(xc(0:8, :, 0:6))
    call random_number(rf)
    xf = 0.0_mp
    call interpolate(tx, ty, 0, nyf - 1, h, 0, xc, h, xf, .false., t)
    rc = 0.0_mp
    call restrict_add(tx, ty, 0, nyf - 1, rf, h, 0, rc, t)
    lhs = sum(real(xf(0:nxf - 1, :, 0:nyf - 1), rp) * real(rf, rp))
    rhs = sum(real(xc(0:8, :, 0:6), rp) * real(rc(0:8, :, 0:6), rp))
    call check_close(lhs, rhs, 1.0e-5_rp, 0.0_rp, merge('restriction = interpolation^T, cubic   ', &
                                                          'restriction = interpolation^T, bilinear', cubic))
    ! Interpolation reproduces a constant (the weights sum to 1).
    xc = 0.0_mp
    xc(0:8, :, 0:6) = 2.5_mp
    call interpolate(tx, ty, 0, nyf - 1, h, 0, xc, h, xf, .false., t)
    call check_close(real(maxval(abs(xf(0:nxf - 1, :, 0:nyf - 1) - 2.5_mp)), rp), 0.0_rp, 0.0_rp, 1.0e-6_rp, &
                     'interpolation keeps constants')
  end subroutine test_transpose

  !> interpolate and restrict_add (the regular interior in vector loops,
  !> the rest point by point) against the sums over the transfers' index
  !> arrays, in double precision, on an nxf x nyf lattice: lattices whose
  !> transfers have a regular interior and the small ones whose cubic
  !> weights are all one-sided.
  subroutine test_transfer_reference(nxf, nyf, cubic)
    integer, intent(in) :: nxf, nyf
    logical, intent(in) :: cubic
    integer, parameter :: h = 3
    type(transfer_t) :: tx, ty
    real(mp), allocatable :: xc(:, :, :), xf(:, :, :), rf(:, :, :), rc(:, :, :), t(:, :)
    real(rp), allocatable :: ref(:, :, :), refc(:, :, :)
    integer :: nxc, nyc, i, j, a, b
    character(len=96) :: label
    call transfer_init(tx, nxf, cubic)
    call transfer_init(ty, nyf, cubic)
    nxc = tx%nc
    nyc = ty%nc
    if (nxf >= 33) call check_true(tx%khi - tx%klo >= 8 .and. tx%inject, 'the transfer along x has a regular interior')
    allocate(xc(-h:nxc - 1 + h, 3, -h:nyc - 1 + h), xf(-h:nxf - 1 + h, 3, -h:nyf - 1 + h), rf(0:nxf - 1, 3, 0:nyf - 1))
    allocate(rc(-h:nxc - 1 + h, 3, -h:nyc - 1 + h), t(0:nxc - 1, 3), ref(0:nxf - 1, 3, 0:nyf - 1), refc(0:nxc - 1, 3, 0:nyc - 1))
    xc = 0.0_mp
    call random_number(xc(0:nxc - 1, :, 0:nyc - 1))
    xc = xc - 0.5_mp
    call random_number(rf)
    rf = rf - 0.5_mp
    xf = 0.0_mp
    call random_number(xf(0:nxf - 1, :, 0:nyf - 1))
    ref = real(xf(0:nxf - 1, :, 0:nyf - 1), rp)
    ! xf = xf + P xc, and P^T rf, from the index arrays
    refc = 0.0_rp
    do j = 0, nyf - 1
      do i = 0, nxf - 1
        do b = 1, ty%n(j)
          do a = 1, tx%n(i)
            ref(i, :, j) = ref(i, :, j) + tx%w(a, i) * ty%w(b, j) * real(xc(tx%c(a, i), :, ty%c(b, j)), rp)
            refc(tx%c(a, i), :, ty%c(b, j)) = refc(tx%c(a, i), :, ty%c(b, j)) + tx%w(a, i) * ty%w(b, j) * real(rf(i, :, j), rp)
          end do
        end do
      end do
    end do
    call interpolate(tx, ty, 0, nyf - 1, h, 0, xc, h, xf, .true., t)
    rc = 0.0_mp
    call restrict_add(tx, ty, 0, nyf - 1, rf, h, 0, rc, t)
    write(label, '(a, i0, a, i0, a, a)') 'interpolation, ', nxf, ' x ', nyf, ', ', merge('cubic ', 'linear', cubic)
    call check_close(maxval(abs(real(xf(0:nxf - 1, :, 0:nyf - 1), rp) - ref)), 0.0_rp, 0.0_rp, 1.0e-6_rp, trim(label))
    write(label, '(a, i0, a, i0, a, a)') 'restriction, ', nxf, ' x ', nyf, ', ', merge('cubic ', 'linear', cubic)
    call check_close(maxval(abs(real(rc(0:nxc - 1, :, 0:nyc - 1), rp) - refc)), 0.0_rp, 0.0_rp, 1.0e-5_rp, trim(label))
  end subroutine test_transfer_reference

  subroutine test_galerkin(r, cubic, lines, nodal)
    integer, intent(in) :: r
    logical, intent(in) :: cubic
    logical, intent(in), optional :: lines
    real(rp), intent(in), optional :: nodal   !< contact's node blocks (random_operator)
    integer, parameter :: nx = 17, ny = 9
    type(stencil_t) :: st, sc
    type(transfer_t) :: tx, ty
    real(rp), allocatable :: dense(:, :), p(:, :), ac_dense(:, :), ac(:, :, :, :, :, :), bx(:, :, :, :, :), rw(:, :, :, :)
    integer :: rc, nxc, nyc, i, j, a, b, c, ic, jc, di, dj, c1, c2
    real(rp) :: err, scale, v
    character(len=64) :: label
    call random_operator(nx, ny, r, 1.0_rp, 1.0_rp, st, dense, lines, nodal)
    if (present(lines)) call check_true(st%nb == 16, 'the lines of the elements: 16 offsets at reach 2')
    call transfer_init(tx, nx, cubic)
    call transfer_init(ty, ny, cubic)
    nxc = tx%nc
    nyc = ty%nc
    allocate(p(3 * nx * ny, 3 * nxc * nyc))
    p = 0.0_rp
    do j = 0, ny - 1
      do i = 0, nx - 1
        do b = 1, ty%n(j)
          do a = 1, tx%n(i)
            do c = 1, 3
              p(gidx(nx, i, j, c), gidx(nxc, tx%c(a, i), ty%c(b, j), c)) = tx%w(a, i) * ty%w(b, j)
            end do
          end do
        end do
      end do
    end do
    ac_dense = matmul(transpose(p), matmul(dense, p))
    rc = max(coarse_reach(tx, r), coarse_reach(ty, r))
    call stencil_init(sc, nxc, nyc, 0, nyc - 1, rc)
    allocate(ac(0:nxc - 1, 3, 3, -rc:rc, -rc:rc, 0:nyc - 1))
    ac = 0.0_rp
    allocate(bx(0:nxc - 1, 3, 3, -rc:rc, -r:r), rw(0:nx - 1, 3, 3, 2))
    call galerkin_add(st, tx, ty, rc, 0, ac, bx, rw)
    ! Every non-zero of the dense product lies within the predicted reach,
    ! and every block equals it.
    err = 0.0_rp
    scale = maxval(abs(ac_dense))
    do jc = 0, nyc - 1
      do ic = 0, nxc - 1
        do j = 0, nyc - 1
          do i = 0, nxc - 1
            di = i - ic
            dj = j - jc
            do c2 = 1, 3
              do c1 = 1, 3
                v = ac_dense(gidx(nxc, ic, jc, c1), gidx(nxc, i, j, c2))
                if (abs(di) > rc .or. abs(dj) > rc) then
                  err = max(err, abs(v))
                else
                  err = max(err, abs(v - ac(ic, c1, c2, di, dj, jc)))
                end if
              end do
            end do
          end do
        end do
      end do
    end do
    write(label, '(a, i0, a, l1, a, l1, a, l1)') 'Galerkin P^T A P, reach ', r, ', cubic ', cubic, ', lines ', present(lines), &
      ', node blocks ', present(nodal)
    call check_close(err, 0.0_rp, 0.0_rp, 1.0e-12_rp * scale, trim(label))
    call stencil_finish(sc, ac)
    call check_true(all(sc%ainv == sc%ainv), 'coarse diagonal blocks inverted')
  end subroutine test_galerkin

  subroutine test_smoother(r, nx, nodal)
    integer, intent(in) :: r    !< reach: 1 and 2 take point_row's fixed-offset routines, 3 its general loop
    integer, intent(in) :: nx   !< nodes a row
    real(rp), intent(in), optional :: nodal   !< contact's node blocks (random_operator)
    integer, parameter :: ny = 7
    type(stencil_t) :: st
    real(rp), allocatable :: dense(:, :), v(:), xref(:), ad(:, :), xd(:), bd(:)
    real(mp) :: x(-r:nx - 1 + r, 3, -r:ny - 1 + r), rhs(0:nx - 1, 3, 0:ny - 1), res(0:nx - 1, 3, 0:ny - 1), t(0:nx - 1, 3)
    real(mp) :: x0(-r:nx - 1 + r, 3, -r:ny - 1 + r), x1(-r:nx - 1 + r, 3, -r:ny - 1 + r), low(0:nx - 1, 3, 0:ny - 1)
    integer :: k, n, i, j, c, ipiv(3 * nx * ny), info
    character(len=40) :: tag
    write(tag, '(a, i0, a, i0, a)') ' (reach ', r, ', nx ', nx, ')'
    if (present(nodal)) tag = tag(1:len_trim(tag) - 1) // ', node blocks)'
    ! Diagonally dominant: mass 30 against up to 24 neighbours of stiffness
    ! <= 1.5 (90 against the 48 of reach 3). Node blocks keep it so, and
    ! the 30 sweeps below must do with them too: 3 x 3 blocks inverted whole.
    call random_operator(nx, ny, r, merge(30.0_rp, 90.0_rp, r <= 2), 1.0_rp, st, dense, nodal=nodal)
    n = 3 * nx * ny
    allocate(v(n))
    call random_number(v)
    xref = v
    ad = dense
    call dgesv(n, 1, dense, n, ipiv, xref, n, info)
    call check_true(info == 0, 'dense solve')
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          rhs(i, c, j) = real(v(gidx(nx, i, j, c)), mp)
        end do
      end do
    end do
    x = 0.0_mp
    do k = 1, 30
      call gs_sweep(st, r, x, rhs, .true., t)
      call gs_sweep(st, r, x, rhs, .false., t)
    end do
    call check_close(error_to_ref(nx, ny, r, x, xref), 0.0_rp, 0.0_rp, 1.0e-5_rp * maxval(abs(xref)), 'symmetric Gauss-Seidel converges to A^-1 b' // trim(tag))
    call residual(st, r, x, rhs, res)
    call check_true(maxval(abs(res)) < 1.0e-4 * maxval(abs(rhs)), 'its residual is small' // trim(tag))
    ! The same with the sums over the rows below kept by the forward sweep
    ! for the backward one: one symmetric sweep from a random start equals
    ! the one without (to single-precision rounding), and 30 converge.
    call random_number(x0)
    x0(:, :, -r:-1) = 0.0_mp
    x0(:, :, ny:) = 0.0_mp
    x0(-r:-1, :, :) = 0.0_mp
    x0(nx:, :, :) = 0.0_mp
    x = x0
    call gs_sweep(st, r, x, rhs, .true., t)
    call gs_sweep(st, r, x, rhs, .false., t)
    x1 = x0
    call gs_sweep(st, r, x1, rhs, .true., t, low)
    call gs_sweep(st, r, x1, rhs, .false., t, low)
    call check_close(real(maxval(abs(x1 - x)), rp), 0.0_rp, 0.0_rp, 1.0e-5_rp * real(maxval(abs(x)), rp), &
                     'symmetric sweep with the kept sums over the rows below' // trim(tag))
    x1 = 0.0_mp
    do k = 1, 30
      call gs_sweep(st, r, x1, rhs, .true., t, low)
      call gs_sweep(st, r, x1, rhs, .false., t, low)
    end do
    call check_close(error_to_ref(nx, ny, r, x1, xref), 0.0_rp, 0.0_rp, 1.0e-5_rp * maxval(abs(xref)), 'it converges to A^-1 b too' // trim(tag))
    ! One forward and one backward sweep from a random start against block
    ! Gauss-Seidel on the dense matrix, node by node in the sweep's order
    ! (rows, then the points of a row): the order matters, converging alone
    ! would not show it.
    allocate(xd(n), bd(n))
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          xd(gidx(nx, i, j, c)) = real(x0(i, c, j), rp)
          bd(gidx(nx, i, j, c)) = real(rhs(i, c, j), rp)
        end do
      end do
    end do
    x = x0
    call gs_sweep(st, r, x, rhs, .true., t)
    call dense_gs_sweep(nx, ny, ad, bd, xd, .true., r == 1)
    call check_close(error_to_ref(nx, ny, r, x, xd), 0.0_rp, 0.0_rp, 1.0e-5_rp * maxval(abs(xd)), &
                     'a forward sweep is block Gauss-Seidel in its order (rows; reach 1: odd points, even)' // trim(tag))
    call gs_sweep(st, r, x, rhs, .false., t)
    call dense_gs_sweep(nx, ny, ad, bd, xd, .false., r == 1)
    call check_close(error_to_ref(nx, ny, r, x, xd), 0.0_rp, 0.0_rp, 1.0e-5_rp * maxval(abs(xd)), &
                     'a backward sweep is block Gauss-Seidel in reverse order' // trim(tag))
    ! A forward sweep of rows 2..3 only (stencil_mg's seam sweep): block
    ! Gauss-Seidel over their nodes, the other rows kept.
    x = x0
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          xd(gidx(nx, i, j, c)) = real(x0(i, c, j), rp)
        end do
      end do
    end do
    call gs_sweep(st, r, x, rhs, .true., t, rows=[2, 3])
    call dense_gs_sweep(nx, ny, ad, bd, xd, .true., r == 1, rows=[2, 3])
    call check_close(error_to_ref(nx, ny, r, x, xd), 0.0_rp, 0.0_rp, 1.0e-5_rp * maxval(abs(xd)), &
                     'a forward sweep of rows 2..3 is block Gauss-Seidel of their nodes' // trim(tag))
  end subroutine test_smoother

  !> The product in double precision from the single-precision difference
  !> form (stencil_product_mixed) against S in double precision
  !> (offset_product's stencil_product) on rows ys..ye of an 11 x 9 lattice,
  !> reach r: a random x (to single rounding of the blocks), and, on a stiff
  !> operator (mass 1e-3 against links of 1e3), a constant x, for which S x
  !> is the small mass term alone: there the difference form keeps the
  !> relative error at single rounding (blocks stored whole in single
  !> precision would be off by 100 %).
  subroutine test_product_mixed(r, ys, ye, nx)
    integer, intent(in) :: r, ys, ye
    integer, intent(in) :: nx   !< nodes a row
    integer, parameter :: ny = 9
    type(stencil_t) :: st
    real(rp), allocatable :: full(:, :, :, :, :), x(:, :, :), y(:, :, :), yd(:, :, :), xs(:, :, :), acc(:, :)
    real(mp), allocatable :: ds(:, :)
    real(rp) :: rnd(3, 3), mass, stiff, scale
    integer :: i, j, di, dj, c, gys, gye, pass, k0
    character(len=96) :: label
    gys = max(0, ys - r)
    gye = min(ny - 1, ye + r)
    allocate(full(0:nx - 1, 3, 3, offset_count(r), 0:ny - 1), x(3, 0:nx - 1, gys:gye), y(3, 0:nx - 1, ys:ye), yd(3, 0:nx - 1, ys:ye))
    allocate(xs(-r:nx - 1 + r, 3, 0:2 * r), acc(0:nx - 1, 4), ds(0:nx - 1, 3))
    do pass = 1, 2
      mass = merge(30.0_rp, 1.0e-3_rp, pass == 1)
      stiff = merge(1.0_rp, 1.0e3_rp, pass == 1)
      full = 0.0_rp
      k0 = offset_slot(r, 0, 0)
      do j = 0, ny - 1
        do i = 0, nx - 1
          do c = 1, 3
            full(i, c, c, k0, j) = mass
          end do
          do dj = -r, r
            do di = -r, r
              if (offset_slot(r, di, dj) == 0 .or. (di == 0 .and. dj == 0)) cycle
              if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) cycle
              call random_number(rnd)
              full(i, :, :, offset_slot(r, di, dj), j) = -stiff * (0.5_rp + rnd)
              full(i, :, :, k0, j) = full(i, :, :, k0, j) + stiff * (0.5_rp + rnd)
            end do
          end do
        end do
      end do
      call stencil_init(st, nx, ny, ys, ye, r, lines=.true.)
      call stencil_from_full(st, full(:, :, :, :, ys:ye))
      if (pass == 1) then
        call random_number(x)
        x = x - 0.5_rp
      else
        x = 1.0_rp
      end if
      call stencil_product_mixed(st, gys, gye, x, y, xs, acc, ds)
      call stencil_product(nx, ny, ys, ye, gys, gye, r, full(:, :, :, :, ys:ye), x, yd)
      if (pass == 1) then
        scale = 2.0_rp * stiff * offset_count(r) * maxval(abs(x))
        write(label, '(a, i0, a, i0, a, i0, a, i0)') 'mixed product, random x, reach ', r, ', rows ', ys, '..', ye, ', nx ', nx
      else
        scale = maxval(abs(yd))
        call check_close(scale, mass, 1.0e-7_rp, 0.0_rp, 'S times a constant is its mass term')
        write(label, '(a, i0, a, i0, a, i0, a, i0)') 'mixed product, stiff S, constant x, reach ', r, ', rows ', ys, '..', ye, ', nx ', nx
      end if
      call check_close(maxval(abs(y - yd)), 0.0_rp, 0.0_rp, 1.0e-6_rp * scale, trim(label))
    end do
  end subroutine test_product_mixed

  !> The product formed during a backward sweep (gs_sweep's xs, acc, ds,
  !> y) and the rows it leaves to level_product_rows, on rows ys..ye of an
  !> nx x 9 lattice (a strip: the ghost rows are a neighbour's, not
  !> changed by the sweep), against stencil_product_mixed of the swept x
  !> widened to double: the same arithmetic, so equal bit for bit. A
  !> product formed from a row before the sweep had finished it, or from
  !> the wrong rows, would differ by the sweep's change.
  subroutine test_fused_product(r, ys, ye, nx)
    integer, intent(in) :: r, ys, ye, nx
    integer, parameter :: ny = 9
    type(stencil_t) :: st
    real(rp), allocatable :: full(:, :, :, :, :), xw(:, :, :), y(:, :, :), yref(:, :, :), xs(:, :, :), acc(:, :)
    real(mp), allocatable :: ds(:, :), x(:, :, :), rhs(:, :, :), t(:, :), low(:, :, :)
    real(rp) :: rnd(3, 3)
    integer :: i, j, di, dj, c, gys, gye, k0
    integer(c_long) :: m0
    character(len=96) :: label
    gys = max(0, ys - r)
    gye = min(ny - 1, ye + r)
    allocate(full(0:nx - 1, 3, 3, offset_count(r), 0:ny - 1))
    allocate(xw(3, 0:nx - 1, gys:gye), y(3, 0:nx - 1, ys:ye), yref(3, 0:nx - 1, ys:ye))
    allocate(xs(-r:nx - 1 + r, 3, 0:2 * r), acc(0:nx - 1, 4), ds(0:nx - 1, 3))
    allocate(x(-r:nx - 1 + r, 3, ys - r:ye + r), rhs(0:nx - 1, 3, ys:ye), t(0:nx - 1, 3), low(0:nx - 1, 3, ys:ye))
    full = 0.0_rp
    k0 = offset_slot(r, 0, 0)
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          full(i, c, c, k0, j) = 30.0_rp
        end do
        do dj = -r, r
          do di = -r, r
            if (offset_slot(r, di, dj) == 0 .or. (di == 0 .and. dj == 0)) cycle
            if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) cycle
            call random_number(rnd)
            full(i, :, :, offset_slot(r, di, dj), j) = -(0.5_rp + rnd)
            full(i, :, :, k0, j) = full(i, :, :, k0, j) + 0.5_rp + rnd
          end do
        end do
      end do
    end do
    call stencil_init(st, nx, ny, ys, ye, r, lines=.true.)
    call stencil_from_full(st, full(:, :, :, :, ys:ye))
    call random_number(x)
    x = x - 0.5_mp
    x(-r:-1, :, :) = 0.0_mp
    x(nx:, :, :) = 0.0_mp
    call random_number(rhs)
    y = -1.0_rp
    m0 = malloc_calls()
    call sweep_with_product(st, r, ys, ye, x, rhs, t, low, xs, acc, ds, y)
    m0 = malloc_calls() - m0
    write(label, '(a, i0, a, i0, a, i0)') 'no heap allocation in the sweeps and products, reach ', r, ', rows ', ys, '..', ye
    call check_true(m0 == 0, trim(label))
    call widened(nx, r, ys - r, gys, gye, x, xw)
    call stencil_product_mixed(st, gys, gye, xw, yref, xs, acc, ds)
    write(label, '(a, i0, a, i0, a, i0, a, i0)') 'product formed in the backward sweep, reach ', r, ', rows ', ys, '..', ye, &
      ', nx ', nx
    call check_close(maxval(abs(y - yref)), 0.0_rp, 0.0_rp, 0.0_rp, trim(label))
  end subroutine test_fused_product

  !> A paired operator on rows ys..ye of an nx x 9 lattice (every block
  !> B(p, o) drawn once for the pair p, p + o and stored in both rows, as
  !> the assembly writes a link's block), made into two stencils, one with
  !> paired set: a forward and a backward sweep with the product formed in
  !> it (and level_product_rows for the strip's ends), and the product
  !> stencil_product_mixed, must agree bit for bit. Control: with B(p, o)
  !> and B(p + o, -o) drawn apart, the paired stencil's sweep differs.
  subroutine test_paired(r, ys, ye, nx)
    integer, intent(in) :: r, ys, ye, nx
    integer, parameter :: ny = 9
    type(stencil_t) :: st(2)
    real(rp), allocatable :: full(:, :, :, :, :), xw(:, :, :), y(:, :, :, :), yp(:, :, :, :), xs(:, :, :), acc(:, :)
    real(mp), allocatable :: ds(:, :), x0(:, :, :), x(:, :, :, :), rhs(:, :, :), t(:, :), low(:, :, :)
    real(rp) :: rnd(3, 3)
    integer :: i, j, di, dj, c, gys, gye, k0, m, pass
    character(len=96) :: label
    gys = max(0, ys - r)
    gye = min(ny - 1, ye + r)
    allocate(full(0:nx - 1, 3, 3, offset_count(r), 0:ny - 1))
    allocate(xw(3, 0:nx - 1, gys:gye), y(3, 0:nx - 1, ys:ye, 2), yp(3, 0:nx - 1, ys:ye, 2))
    allocate(xs(-r:nx - 1 + r, 3, 0:2 * r), acc(0:nx - 1, 4), ds(0:nx - 1, 3))
    allocate(x0(-r:nx - 1 + r, 3, ys - r:ye + r), x(-r:nx - 1 + r, 3, ys - r:ye + r, 2))
    allocate(rhs(0:nx - 1, 3, ys:ye), t(0:nx - 1, 3), low(0:nx - 1, 3, ys:ye))
    call random_number(x0)
    x0 = x0 - 0.5_mp
    x0(-r:-1, :, :) = 0.0_mp
    x0(nx:, :, :) = 0.0_mp
    call random_number(rhs)
    k0 = offset_slot(r, 0, 0)
    do pass = 1, 2
      ! pass 1 paired, pass 2 (the control) not
      full = 0.0_rp
      do j = 0, ny - 1
        do i = 0, nx - 1
          do c = 1, 3
            full(i, c, c, k0, j) = full(i, c, c, k0, j) + 30.0_rp
          end do
          do dj = 0, r
            do di = -r, r
              if (dj == 0 .and. di <= 0) cycle
              if (offset_slot(r, di, dj) == 0) cycle
              if (i + di < 0 .or. i + di >= nx .or. j + dj >= ny) cycle
              call random_number(rnd)
              full(i, :, :, offset_slot(r, di, dj), j) = -(0.5_rp + rnd)
              if (pass == 2) call random_number(rnd)
              full(i + di, :, :, offset_slot(r, -di, -dj), j + dj) = -(0.5_rp + rnd)
            end do
          end do
        end do
      end do
      do j = 0, ny - 1
        do i = 0, nx - 1
          do dj = -r, r
            do di = -r, r
              if (offset_slot(r, di, dj) == 0 .or. (di == 0 .and. dj == 0)) cycle
              full(i, :, :, k0, j) = full(i, :, :, k0, j) - full(i, :, :, offset_slot(r, di, dj), j)
            end do
          end do
        end do
      end do
      do m = 1, 2
        call stencil_init(st(m), nx, ny, ys, ye, r, lines=.true.)
        call stencil_from_full(st(m), full(:, :, :, :, ys:ye))
        st(m)%paired = m == 2
        x(:, :, :, m) = x0
        y(:, :, :, m) = -1.0_rp
        call sweep_with_product(st(m), r, ys, ye, x(:, :, :, m), rhs, t, low, xs, acc, ds, y(:, :, :, m))
        call widened(nx, r, ys - r, gys, gye, x0, xw)
        call stencil_product_mixed(st(m), gys, gye, xw, yp(:, :, :, m), xs, acc, ds)
      end do
      write(label, '(a, i0, a, i0, a, i0, a, i0)') 'reach ', r, ', rows ', ys, '..', ye, ', nx ', nx
      if (pass == 1) then
        call check_true(all(x(:, :, :, 1) == x(:, :, :, 2)), 'paired: the sweeps, ' // trim(label))
        call check_true(all(y(:, :, :, 1) == y(:, :, :, 2)), 'paired: the product in the sweep, ' // trim(label))
        call check_true(all(yp(:, :, :, 1) == yp(:, :, :, 2)), 'paired: the product, ' // trim(label))
      else
        call check_true(any(x(:, :, :, 1) /= x(:, :, :, 2)) .and. any(yp(:, :, :, 1) /= yp(:, :, :, 2)), &
                        'an unpaired operator taken as paired differs (control), ' // trim(label))
      end if
    end do
  end subroutine test_paired

  !> One symmetric sweep of x (rows ys..ye of st, ghost rows r) with
  !> y = A x of the result formed in its backward sweep, and the strip's
  !> first and last r rows after it (level_product_rows), as module
  !> stencil_mg's smooth does on the finest level.
  subroutine sweep_with_product(st, r, ys, ye, x, rhs, t, low, xs, acc, ds, y)
    type(stencil_t), intent(in) :: st
    integer, intent(in) :: r, ys, ye
    real(mp), intent(inout), contiguous :: x(:, :, :)
    real(mp), intent(in) :: rhs(:, :, :)
    ! (t contiguous as gs_sweep's: else the call packs it, a malloc)
    real(mp), intent(inout), contiguous :: t(:, :)
    real(mp), intent(inout) :: low(:, :, :), ds(:, :)
    real(rp), intent(inout) :: xs(:, :, :), acc(:, :), y(:, :, :)
    call gs_sweep(st, r, x, rhs, .true., t, low)
    call gs_sweep(st, r, x, rhs, .false., t, low, xs, acc, ds, y)
    call level_product_rows(st, r, x, ys, min(ys + r - 1, ye), xs, acc, ds, y)
    call level_product_rows(st, r, x, max(ye - r + 1, ys + r), ye, xs, acc, ds, y)
  end subroutine sweep_with_product

  !> xw(3, 0:nx-1, gys:gye) = the rows gys..gye of the padded
  !> single-precision x(-r:nx-1+r, 3, jlo:), widened to double precision
  !> in the layout of a 3-dof DMDA vector.
  subroutine widened(nx, r, jlo, gys, gye, x, xw)
    integer, intent(in) :: nx, r, jlo, gys, gye
    real(mp), intent(in) :: x(-r:, :, jlo:)
    real(rp), intent(out) :: xw(:, 0:, gys:)
    integer :: i, j, c
    do j = gys, gye
      do i = 0, nx - 1
        do c = 1, 3
          xw(c, i, j) = real(x(i, c, j), rp)
        end do
      end do
    end do
  end subroutine widened

  !> One block Gauss-Seidel sweep on the dense matrix a (node order of
  !> gidx): x_p = A_pp^-1 (b_p - sum_{q /= p} A_pq x_q), nodes in
  !> lexicographic order (rows slowest) or its reverse.
  subroutine dense_gs_sweep(nx, ny, a, b, x, forward, colours, rows)
    integer, intent(in) :: nx, ny
    real(rp), intent(in) :: a(:, :), b(:)
    real(rp), intent(inout) :: x(:)
    logical, intent(in) :: forward
    !> the points of a row in two colours (rows of reach 1: the odd
    !> points, then the even ones; backward the reverse)
    logical, intent(in) :: colours
    integer, intent(in), optional :: rows(2)   !< only the nodes of rows rows(1)..rows(2)
    real(rp) :: app(3, 3), s(3)
    integer :: m, mm, p, c, ip(3), info, ipiv(3), order(0:nx * ny - 1), j, i, n, j0, j1
    j0 = 0
    j1 = ny - 1
    if (present(rows)) then
      j0 = rows(1)
      j1 = rows(2)
    end if
    n = 0
    do j = j0, j1
      if (colours) then
        do i = 1, nx - 1, 2
          order(n) = i + nx * j
          n = n + 1
        end do
        do i = 0, nx - 1, 2
          order(n) = i + nx * j
          n = n + 1
        end do
      else
        do i = 0, nx - 1
          order(n) = i + nx * j
          n = n + 1
        end do
      end if
    end do
    do mm = 0, n - 1
      m = merge(mm, n - 1 - mm, forward)
      p = order(m)
      ip = [(3 * p + c, c = 1, 3)]
      s = b(ip) - matmul(a(ip, :), x) + matmul(a(ip, ip), x(ip))
      app = a(ip, ip)
      call dgesv(3, 1, app, 3, ipiv, s, 3, info)
      x(ip) = s
    end do
  end subroutine dense_gs_sweep

  !> max |xs - xref| over an nx x ny lattice (xs padded by r, xref dense).
  real(rp) function error_to_ref(nx, ny, r, xs, xref) result(err)
    integer, intent(in) :: nx, ny, r
    real(mp), intent(in) :: xs(-r:, :, -r:)
    real(rp), intent(in) :: xref(:)
    integer :: i, j, c
    err = 0.0_rp
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          err = max(err, abs(real(xs(i, c, j), rp) - xref(gidx(nx, i, j, c))))
        end do
      end do
    end do
  end function error_to_ref

  !> The finest level from S by stencil offset (stencil_from_full: tiles of
  !> 16 nodes, the row sums and inverses formed for a tile at once) against
  !> the same operator stored node by node (stencil_put_row): the blocks
  !> equal, the row sums and inverted diagonal blocks to single rounding;
  !> 37 nodes a row (two whole tiles and a part), one node with a singular
  !> diagonal block (its inverse the identity in both).
  subroutine test_from_full(r)
    integer, intent(in) :: r
    integer, parameter :: nx = 37, ny = 5, isg = 20, jsg = 2
    type(stencil_t) :: st, sf
    real(rp), allocatable :: dense(:, :), full(:, :, :, :, :)
    real(rp) :: blk(3, 3, -r:r, -r:r)
    integer :: i, j, di, dj, c1, c2, k
    integer(c_long) :: m0
    character(len=16) :: tag
    write(tag, '(a, i0, a)') ' (reach ', r, ')'
    call random_operator(nx, ny, r, 30.0_rp, 1.0_rp, st, dense, lines=.true.)
    allocate(full(0:nx - 1, 3, 3, offset_count(r), 0:ny - 1))
    full = 0.0_rp
    do j = 0, ny - 1
      do i = 0, nx - 1
        blk = 0.0_rp
        do dj = -r, r
          do di = -r, r
            k = offset_slot(r, di, dj)
            if (k == 0) cycle
            if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) cycle
            do c2 = 1, 3
              do c1 = 1, 3
                blk(c1, c2, di, dj) = dense(gidx(nx, i, j, c1), gidx(nx, i + di, j + dj, c2))
              end do
            end do
            full(i, :, :, k, j) = blk(:, :, di, dj)
          end do
        end do
        if (i == isg .and. j == jsg) then
          blk(:, :, 0, 0) = 0.0_rp
          full(i, :, :, offset_slot(r, 0, 0), j) = 0.0_rp
          call stencil_put_row(st, i, j, blk)
        end if
      end do
    end do
    call stencil_init(sf, nx, ny, 0, ny - 1, r, lines=.true.)
    m0 = malloc_calls()
    call stencil_from_full(sf, full)
    m0 = malloc_calls() - m0
    call check_true(m0 == 0, 'from full: no heap allocation (the row sums)' // trim(tag))
    call check_true(all(sf%b == st%b) .and. all(sf%br == st%br), 'from full: the blocks' // trim(tag))
    ! (the same formulas in double precision, rounded once; the compiler may
    ! contract them differently in the vector loop: single rounding apart)
    call check_close(real(maxval(abs(sf%ainv - st%ainv)), rp), 0.0_rp, 0.0_rp, 1.0e-6_rp * real(maxval(abs(st%ainv)), rp), &
                     'from full: the inverted diagonal blocks' // trim(tag))
    call check_close(real(maxval(abs(sf%d - st%d)), rp), 0.0_rp, 0.0_rp, 1.0e-6_rp * real(maxval(abs(st%d)), rp), &
                     'from full: the row sums' // trim(tag))
    call check_true(all(sf%ainv(:, :, isg, jsg) == reshape([1, 0, 0, 0, 1, 0, 0, 0, 1], [3, 3])), &
                    'from full: a singular diagonal block gives the identity' // trim(tag))
  end subroutine test_from_full

  subroutine test_row_sums()
    integer, parameter :: nx = 9, ny = 9, r = 2
    type(stencil_t) :: st
    real(rp), allocatable :: dense(:, :)
    real(mp) :: x(-r:nx - 1 + r, 3, -r:ny - 1 + r), y(0:nx - 1, 3, 0:ny - 1)
    real(rp) :: rounded_err
    integer :: i, j, c
    ! Stiffness 1e6 times the mass: a constant vector sees only the mass.
    call random_operator(nx, ny, r, 1.0_rp, 1.0e6_rp, st, dense)
    x = 0.0_mp
    x(0:nx - 1, :, 0:ny - 1) = 1.0_mp
    call stencil_apply(st, r, x, y)
    call check_close(real(maxval(abs(y - 1.0_mp)), rp), 0.0_rp, 0.0_rp, 1.0e-6_rp, &
                     'difference form: A 1 = mass to single precision, stiffness 1e6')
    ! Rounding the full row instead loses the mass: its error is of the order
    ! of the stiffness times the unit roundoff, here far above the mass.
    rounded_err = 0.0_rp
    do j = 0, ny - 1
      do i = 0, nx - 1
        do c = 1, 3
          rounded_err = max(rounded_err, abs(sum(real(real(dense(gidx(nx, i, j, c), :), mp), rp)) - 1.0_rp))
        end do
      end do
    end do
    call check_true(rounded_err > 1.0e-2_rp, 'rounded full rows would not keep the mass (control)')
  end subroutine test_row_sums

end program test_mg_kernels
