! SPDX-License-Identifier: BSD-2-Clause
!> An in-place ascending sort of a few dozen reals (event times, the
!> identification's stop times): insertion, stable, no work array.
module small_sort
  use kinds, only: rp
  implicit none
  private
  public :: insertion_sort
contains
  !> Sort a ascending in place; equal values keep their order. O(n^2):
  !> for the short lists of the input and identification only.
  pure subroutine insertion_sort(a)
    real(rp), intent(inout) :: a(:)
    real(rp) :: x
    integer :: i, j
    do i = 2, size(a)
      x = a(i)
      j = i - 1
      do while (j >= 1)
        if (a(j) <= x) exit
        a(j + 1) = a(j)
        j = j - 1
      end do
      a(j + 1) = x
    end do
  end subroutine insertion_sort
end module small_sort
