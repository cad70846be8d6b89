! SPDX-License-Identifier: BSD-2-Clause
!> The uniform spatial hash of the cloth's self-contact broad phase (module
!> self_broad; docs/self-contact.md, "Candidate pairs"): boxes put into
!> the cells of size h they overlap, the cells' integer coordinates hashed
!> into a table of a power of 2 at least the number of entries, filled by
!> a counting sort. A query walks the bucket of a cell and keeps the
!> entries whose packed key is that cell's. Plain arrays, no PETSc, no
!> MPI; the grid's arrays are grown only when too short (work_arrays).
module self_hash
  use, intrinsic :: iso_fortran_env, only: int64
  use kinds, only: rp
  use work_arrays, only: grow, grow_from0
  implicit none
  private
  public :: grid_t, cell_of, cell_key, bucket, build_grid

  !> The spatial hash of one set of boxes (arrays at least as long as used).
  type :: grid_t
    integer :: nbucket = 0                 ! a power of 2
    integer, allocatable :: first(:)       ! (0:nbucket+) start of each bucket in item
    integer, allocatable :: item(:)        ! (n+) box number of each entry
    integer(int64), allocatable :: key(:)  ! (n+) the entry's cell, packed (cell_key)
    integer, allocatable :: fill(:)        ! (0:nbucket-1+) the counting sort's counters
  end type grid_t

  integer(int64), parameter :: P1 = 73856093_int64, P2 = 19349663_int64, P3 = 83492791_int64

contains

  !> The integer coordinates of the cell holding y.
  pure function cell_of(y, origin, h) result(c)
    real(rp), intent(in) :: y(3), origin(3), h
    integer(int64) :: c(3)

    c = floor((y - origin) / h, kind=int64)
  end function cell_of

  !> A cell's coordinates (each in 0..2^21-1: self_broad's cell_size keeps them there) in one integer.
  pure integer(int64) function cell_key(c) result(k)
    integer(int64), intent(in) :: c(3)

    k = c(1) + ishft(c(2), 21) + ishft(c(3), 42)
  end function cell_key

  pure integer function bucket(g, c) result(b)
    type(grid_t), intent(in) :: g
    integer(int64), intent(in) :: c(3)

    b = int(iand(ieor(ieor(c(1) * P1, c(2) * P2), c(3) * P3), int(g%nbucket - 1, int64)))
  end function bucket

  !> The hash of boxes lo(:, k) - pad..hi(:, k) + pad: each box in every cell it overlaps
  !> (counting sort); g's arrays grown where too short.
  pure subroutine build_grid(g, lo, hi, pad, origin, h, regrown)
    type(grid_t), intent(inout) :: g
    real(rp), intent(in) :: lo(:, :), hi(:, :), pad, origin(3), h
    integer, intent(inout) :: regrown
    integer(int64) :: clo(3), chi(3), c(3)
    integer :: k, n, b, cx, cy, cz, pass

    n = 0
    do k = 1, size(lo, 2)
      clo = cell_of(lo(:, k) - pad, origin, h)
      chi = cell_of(hi(:, k) + pad, origin, h)
      n = n + int(product(chi - clo + 1))
    end do
    g%nbucket = 1
    do while (g%nbucket < n)
      g%nbucket = 2 * g%nbucket
    end do
    call grow_from0(g%first, g%nbucket, regrown)
    call grow_from0(g%fill, g%nbucket - 1, regrown)
    call grow(g%item, n, regrown)
    call grow(g%key, n, regrown)
    associate (fill => g%fill)
      fill(0:g%nbucket - 1) = 0
      do pass = 1, 2
        do k = 1, size(lo, 2)
          clo = cell_of(lo(:, k) - pad, origin, h)
          chi = cell_of(hi(:, k) + pad, origin, h)
          do cz = 0, int(chi(3) - clo(3))
            do cy = 0, int(chi(2) - clo(2))
              do cx = 0, int(chi(1) - clo(1))
                c = clo + [cx, cy, cz]
                b = bucket(g, c)
                if (pass == 1) then
                  fill(b) = fill(b) + 1
                else
                  g%item(fill(b)) = k
                  g%key(fill(b)) = cell_key(c)
                  fill(b) = fill(b) + 1
                end if
              end do
            end do
          end do
        end do
        if (pass == 1) then
          g%first(0) = 1
          do b = 0, g%nbucket - 1
            g%first(b + 1) = g%first(b) + fill(b)
          end do
          fill(0:g%nbucket - 1) = g%first(0:g%nbucket - 1)
        end if
      end do
    end associate
  end subroutine build_grid

end module self_hash
