! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the product with S stored by stencil offset (module
!> offset_product) against a dense matrix built from the same random
!> blocks: reach 1 and 2, a strip of owned rows in the middle of the
!> lattice (ghost rows above and below), the first and the last rows, a
!> lattice narrower than the stencil. The blocks the elements never couple
!> at reach 2 ((1, 2), (2, 1), ...) and those pointing outside the lattice
!> are set to garbage: the product must not read them.
program test_offset_product
  use kinds, only: rp
  use offset_product, only: stencil_product, offset_count, offset_slot
  use check, only: check_true, check_close_array, check_report
  implicit none

  call one(9, 11, 3, 6, 2, 'reach 2, middle strip')
  call one(9, 11, 0, 10, 2, 'reach 2, whole lattice')
  call one(9, 11, 8, 10, 2, 'reach 2, last rows')
  call one(9, 11, 0, 1, 1, 'reach 1, first rows')
  call one(7, 8, 2, 5, 1, 'reach 1, middle strip')
  call one(3, 6, 1, 4, 2, 'reach 2, lattice narrower than the stencil')
  call one(2, 5, 0, 4, 1, 'reach 1, two columns')
  call check_report()

contains

  subroutine one(nx, ny, ys, ye, w, what)
    integer, intent(in) :: nx, ny, ys, ye, w
    character(*), intent(in) :: what
    real(rp), allocatable :: st(:, :, :, :, :), x(:, :, :), y(:, :, :), dense(:, :), xd(:), yd(:)
    integer :: gys, gye, i, j, di, dj, r, c, n, k
    logical :: coupled, taken(17)
    gys = max(0, ys - w)
    gye = min(ny - 1, ye + w)
    n = 3 * nx * ny
    allocate(st(0:nx - 1, 3, 3, offset_count(w), ys:ye), x(3, 0:nx - 1, gys:gye), y(3, 0:nx - 1, ys:ye))
    allocate(dense(n, n), xd(n), yd(n))
    call random_number(st)
    call random_number(x)
    x = x - 0.5_rp
    taken = .false.
    do dj = -w, w
      do di = -w, w
        ! linked neighbours, and the far ends of triples along x, y, diagonals
        coupled = max(abs(di), abs(dj)) <= 1 .or. (abs(di) == 2 .and. dj == 0) .or. (di == 0 .and. abs(dj) == 2) &
                  .or. (abs(di) == 2 .and. abs(dj) == 2)
        k = offset_slot(w, di, dj)
        call check_true((k > 0) .eqv. coupled, what//': offset stored iff the elements couple it')
        if (k > 0) then
          call check_true(k <= offset_count(w) .and. .not. taken(k), what//': slot in range and new')
          taken(k) = .true.
        end if
      end do
    end do
    dense = 0.0_rp
    do j = ys, ye
      do i = 0, nx - 1
        do dj = -w, w
          do di = -w, w
            k = offset_slot(w, di, dj)
            if (k == 0) cycle
            if (i + di < 0 .or. i + di >= nx .or. j + dj < 0 .or. j + dj >= ny) then
              st(i, :, :, k, j) = 1.0e30_rp      ! never to be read
              cycle
            end if
            do c = 1, 3
              do r = 1, 3
                dense(gidx(nx, i, j, r), gidx(nx, i + di, j + dj, c)) = st(i, r, c, k, j)
              end do
            end do
          end do
        end do
      end do
    end do
    xd = 0.0_rp
    do j = gys, gye
      do i = 0, nx - 1
        do c = 1, 3
          xd(gidx(nx, i, j, c)) = x(c, i, j)
        end do
      end do
    end do
    yd = matmul(dense, xd)
    call stencil_product(nx, ny, ys, ye, gys, gye, w, st, x, y)
    call check_close_array(reshape(y, [size(y)]), yd(gidx(nx, 0, ys, 1):gidx(nx, nx - 1, ye, 3)), 1.0e-13_rp, 0.0_rp, what)
  end subroutine one

  !> Dense index of (node i, j; component c) on a lattice nx wide.
  pure integer function gidx(nx, i, j, c)
    integer, intent(in) :: nx, i, j, c
    gidx = 3 * (i + nx * j) + c
  end function gidx

end program test_offset_product
