! SPDX-License-Identifier: BSD-2-Clause
!> The word of a list nearest to a misspelt one, for "did you mean" hints
!> (module option_check: an option nothing reads, against the options the
!> run knows). The distance is the optimal string alignment distance: the
!> fewest insertions, deletions, substitutions and swaps of two neighbours
!> that turn one word into the other (-ts_tpye is 1 from -ts_type).
!> tests/unit/test_nearest_word.f90.
module nearest_word
  implicit none
  private
  public :: edit_distance, nearest

contains

  !> The optimal string alignment distance between a and b (case matters).
  pure integer function edit_distance(a, b) result(dist)
    character(*), intent(in) :: a, b
    integer :: d(0:len(a), 0:len(b))
    integer :: i, j, cost
    do i = 0, len(a)
      d(i, 0) = i
    end do
    do j = 0, len(b)
      d(0, j) = j
    end do
    do j = 1, len(b)
      do i = 1, len(a)
        cost = merge(0, 1, a(i:i) == b(j:j))
        d(i, j) = min(d(i - 1, j) + 1, d(i, j - 1) + 1, d(i - 1, j - 1) + cost)
        if (i > 1 .and. j > 1) then
          if (a(i:i) == b(j - 1:j - 1) .and. a(i - 1:i - 1) == b(j:j)) d(i, j) = min(d(i, j), d(i - 2, j - 2) + 1)
        end if
      end do
    end do
    dist = d(len(a), len(b))
  end function edit_distance

  !> The word of words (trimmed) nearest to word: the smallest distance, if
  !> at most max(2, len(word)/5) (a slip, not another word), else the
  !> shortest word that word begins (an option cut short, -ts_adapt for
  !> -ts_adapt_type); '' when neither. Ties: the first in the list.
  function nearest(word, words) result(best)
    character(*), intent(in) :: word, words(:)
    character(:), allocatable :: best
    integer :: k, d, dmin, n
    best = ''
    dmin = max(2, len(word) / 5) + 1
    do k = 1, size(words)
      n = len_trim(words(k))
      if (n == 0 .or. abs(n - len(word)) >= dmin) cycle
      d = edit_distance(word, words(k)(1:n))
      if (d < dmin .and. d > 0) then
        dmin = d
        best = words(k)(1:n)
      end if
    end do
    if (len(best) > 0) return
    do k = 1, size(words)
      n = len_trim(words(k))
      if (n <= len(word)) cycle
      if (words(k)(1:len(word)) /= word) cycle
      if (len(best) > 0) then
        if (n >= len(best)) cycle
      end if
      best = words(k)(1:n)
    end do
  end function nearest

end module nearest_word
