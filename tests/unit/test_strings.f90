! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module strings: the texts are spelled out here (what a
!> reader of a message, attribute or sidecar sees), and real_g0 must read
!> back as the same double, the shortest such text.
program test_strings
  use kinds, only: rp
  use strings, only: itoa, real_es, real_g0, real_list, real_short, real_brief, &
                     count_text, bytes_text, pow10_text, kb_text
  use check, only: check_true, check_report
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, ieee_negative_inf
  implicit none
  real(rp) :: x, y
  character(len=:), allocatable :: t
  real(rp), parameter :: samples(6) = [0.1_rp, 1.0_rp/3.0_rp, -2.5e-300_rp, 6.02214076e23_rp, 1.0_rp, huge(1.0_rp)]
  integer :: k, e

  call check_true(itoa(0) == '0', 'itoa(0)')
  call check_true(itoa(-42) == '-42', 'itoa(-42)')
  call check_true(itoa(huge(1)) == '2147483647', 'itoa(huge)')
  call check_true(itoa(-huge(1) - 1) == '-2147483648', 'itoa(-huge-1)')

  call check_true(real_es(1.0_rp) == '1.0000000000000000E+000', 'real_es(1): '//real_es(1.0_rp))
  call check_true(real_es(-0.5_rp) == '-5.0000000000000000E-001', 'real_es(-0.5): '//real_es(-0.5_rp))

  call check_true(real_g0(ieee_value(x, ieee_quiet_nan)) == 'NaN', 'real_g0(NaN)')
  call check_true(real_g0(ieee_value(x, ieee_positive_inf)) == 'Inf', 'real_g0(+Inf)')
  call check_true(real_g0(ieee_value(x, ieee_negative_inf)) == '-Inf', 'real_g0(-Inf)')
  do k = 1, size(samples)
    t = real_g0(samples(k))
    read(t, *, iostat=e) y
    call check_true(e == 0 .and. y == samples(k), 'real_g0 reads back: '//t)
    ! the shortest: 0.1 and 1 need one significant digit, 1/3 all 16-17
    if (k == 1) call check_true(len(t) < 12, 'real_g0(0.1) is short: '//t)
  end do
  call check_true(real_list([1.5_rp, -2.0_rp]) == real_g0(1.5_rp)//', '//real_g0(-2.0_rp), 'real_list')
  call check_true(real_list([real(rp) ::]) == '', 'real_list of none')
  ! real_short: the value as a user would write it, fixed from 1e-3 to 1e7
  call check_true(real_short(0.1_rp) == '0.1', 'real_short(0.1): '//real_short(0.1_rp))
  call check_true(real_short(-2.5_rp) == '-2.5', 'real_short(-2.5): '//real_short(-2.5_rp))
  call check_true(real_short(0.0_rp) == '0.0', 'real_short(0): '//real_short(0.0_rp))
  call check_true(real_short(1.0e-4_rp) == '1.0E-04', 'real_short(1e-4): '//real_short(1.0e-4_rp))
  call check_true(real_short(ieee_value(x, ieee_quiet_nan)) == 'NaN', 'real_short(NaN)')
  call check_true(real_short(ieee_value(x, ieee_negative_inf)) == '-Infinity', 'real_short(-Inf)')
  do k = 1, size(samples)
    t = real_short(samples(k))
    read(t, *, iostat=e) y
    call check_true(e == 0 .and. y == samples(k), 'real_short reads back: '//t)
  end do
  ! real_brief: six significant digits, no leading blank
  call check_true(real_brief(1.0_rp/3.0_rp) == '3.33333E-01', 'real_brief(1/3): '//real_brief(1.0_rp/3.0_rp))
  call check_true(real_brief(-2.0e10_rp) == '-2.00000E+10', 'real_brief(-2e10): '//real_brief(-2.0e10_rp))
  ! counts, bytes and powers of ten of the run-size messages and --help
  call check_true(count_text(11.0_rp) == '11', 'count_text(11): '//count_text(11.0_rp))
  call check_true(count_text(2.2e10_rp) == '2.20E+10', 'count_text(2.2e10): '//count_text(2.2e10_rp))
  call check_true(bytes_text(3.5e9_rp) == '3.5 GB', 'bytes_text(3.5e9): '//bytes_text(3.5e9_rp))
  call check_true(bytes_text(2.5e6_rp) == '2.5 MB', 'bytes_text(2.5e6): '//bytes_text(2.5e6_rp))
  call check_true(bytes_text(4.0e12_rp) == '4.0 TB', 'bytes_text(4e12): '//bytes_text(4.0e12_rp))
  call check_true(pow10_text(1.0e8_rp) == '1e8', 'pow10_text(1e8): '//pow10_text(1.0e8_rp))
  call check_true(kb_text(1900.0_rp) == '1.9', 'kb_text(1900): '//kb_text(1900.0_rp))
  call check_report()
end program test_strings
