! SPDX-License-Identifier: BSD-2-Clause
!> Minimal assertion helpers for the Fortran unit-test programs.
!> Each check prints one line on failure and counts it; check_report prints
!> 'N passed, N failed' and stops with a non-zero code if anything failed.
module check
  use, intrinsic :: iso_fortran_env, only: real64, output_unit
  implicit none
  private
  public :: check_true, check_close, check_close_array, check_report
  integer, save :: n_pass = 0, n_fail = 0
contains
  !> Record a logical condition.
  subroutine check_true(cond, what)
    logical, intent(in) :: cond
    character(*), intent(in) :: what
    if (cond) then
      n_pass = n_pass + 1
    else
      n_fail = n_fail + 1
      write(output_unit, '(a)') 'FAIL: '//what
    end if
  end subroutine check_true

  !> |a - b| <= atol + rtol*|b|
  subroutine check_close(a, b, rtol, atol, what)
    real(real64), intent(in) :: a, b, rtol, atol
    character(*), intent(in) :: what
    if (abs(a - b) <= atol + rtol*abs(b) .and. a == a) then
      n_pass = n_pass + 1
    else
      n_fail = n_fail + 1
      write(output_unit, '(a,es24.16,a,es24.16)') 'FAIL: '//what//': got ', a, ' expected ', b
    end if
  end subroutine check_close

  !> max|a - b| <= atol + rtol*max|b| over all entries
  subroutine check_close_array(a, b, rtol, atol, what)
    real(real64), intent(in) :: a(:), b(:)
    real(real64), intent(in) :: rtol, atol
    character(*), intent(in) :: what
    real(real64) :: err, scale
    err = maxval(abs(a - b))
    scale = maxval(abs(b))
    if (size(a) == size(b) .and. err <= atol + rtol*scale .and. all(a == a)) then
      n_pass = n_pass + 1
    else
      n_fail = n_fail + 1
      write(output_unit, '(a,es12.4,a,es12.4)') 'FAIL: '//what//': max error ', err, ' scale ', scale
    end if
  end subroutine check_close_array

  !> Print the closing line and stop non-zero on any failure.
  subroutine check_report()
    write(output_unit, '(i0,a,i0,a)') n_pass, ' passed, ', n_fail, ' failed'
    if (n_fail > 0) error stop 1
  end subroutine check_report
end module check
