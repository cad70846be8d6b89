! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module small_sort: sorted lists spelled out here, the
!> empty and one-element lists, and stability seen through signed zeros
!> (0 and -0 compare equal, so a stable sort keeps their order).
program test_small_sort
  use kinds, only: rp
  use small_sort, only: insertion_sort
  use check, only: check_true, check_report
  implicit none
  real(rp) :: a(7), e(0), one(1), z(4)

  a = [0.3_rp, -1.0_rp, 2.5_rp, 0.3_rp, 1.0e-9_rp, -7.0_rp, 0.0_rp]
  call insertion_sort(a)
  call check_true(all(a == [-7.0_rp, -1.0_rp, 0.0_rp, 1.0e-9_rp, 0.3_rp, 0.3_rp, 2.5_rp]), 'seven values ascending')

  call insertion_sort(e)
  call check_true(size(e) == 0, 'the empty list')
  one = [4.0_rp]
  call insertion_sort(one)
  call check_true(one(1) == 4.0_rp, 'one value')

  z = [1.0_rp, 0.0_rp, -0.0_rp, -1.0_rp]
  call insertion_sort(z)
  call check_true(z(1) == -1.0_rp .and. z(4) == 1.0_rp, 'signed zeros: the ends')
  call check_true(.not. sign(1.0_rp, z(2)) < 0.0_rp .and. sign(1.0_rp, z(3)) < 0.0_rp, &
                  'signed zeros: 0 before -0 as they came (stable)')
  call check_report()
end program test_small_sort
