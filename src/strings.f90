! SPDX-License-Identifier: BSD-2-Clause
!> Numbers as text, for messages, attributes and the XDMF sidecar. No PETSc,
!> no MPI: every room may use it (built into the input-text library, the
!> lowest one above the kernels).
module strings
  use kinds, only: rp
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private

  public :: itoa, real_es, real_g0, real_list

contains

  !> An integer without blanks.
  pure function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write(buf, '(i0)') i
    s = trim(buf)
  end function itoa

  !> A double in scientific notation with all 17 significant digits
  !> (es24.16e3, left-adjusted): the same text on every compiler run.
  pure function real_es(x) result(s)
    real(rp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    write(buf, '(es24.16e3)') x
    s = trim(adjustl(buf))
  end function real_es

  !> A double as the shortest text that reads back the same, NaN and Inf
  !> spelled so.
  function real_g0(x) result(s)
    real(rp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=40) :: b
    character(len=16) :: fmt
    real(rp) :: y
    integer :: d, e
    if (x /= x) then
      s = 'NaN'
    else if (.not. ieee_is_finite(x)) then
      s = trim(merge('Inf ', '-Inf', x > 0.0_rp))
    else
      do d = 1, 17
        write(fmt, '(a,i0,a)') '(g0.', d, ')'
        write(b, fmt) x
        read(b, *, iostat=e) y
        if (e == 0 .and. y == x) exit
      end do
      s = trim(adjustl(b))
    end if
  end function real_g0

  !> Doubles as real_g0 text, separated by ', '.
  function real_list(x) result(s)
    real(rp), intent(in) :: x(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(x)
      if (k > 1) s = s//', '
      s = s//real_g0(x(k))
    end do
  end function real_list

end module strings
