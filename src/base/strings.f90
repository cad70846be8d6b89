! SPDX-License-Identifier: BSD-2-Clause
!> Numbers as text, for messages, attributes and the XDMF sidecar: the
!> program's only number-to-string helpers. No PETSc, no MPI: in the base
!> layer (src/base), which every other layer may use.
module strings
  use kinds, only: rp
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private

  public :: itoa, real_es, real_g0, real_list, real_short, real_brief
  public :: count_text, bytes_text, pow10_text, kb_text

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
    s = real_edit(x, '(es24.16e3)')
  end function real_es

  !> x written with the format fmt (at most 32 characters), without the
  !> blanks around it.
  pure function real_edit(x, fmt) result(s)
    real(rp), intent(in) :: x
    character(*), intent(in) :: fmt
    character(len=:), allocatable :: s
    character(len=32) :: buf
    write(buf, fmt) x
    s = trim(adjustl(buf))
  end function real_edit

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

  !> The shortest decimal that reads back as x, in fixed notation from 1e-3
  !> to 1e7 (input messages: the value as the user would write it).
  function real_short(x) result(s)
    real(rp), intent(in) :: x
    character(:), allocatable :: s
    character(40) :: buf, fmt
    real(rp) :: y
    integer :: d, ios
    if (x /= x) then
      s = 'NaN'
      return
    else if (abs(x) > huge(x)) then
      s = merge('+Infinity', '-Infinity', x > 0.0_rp)
      return
    else if (x == 0.0_rp) then
      s = '0.0'
      return
    end if
    do d = 1, 17
      if (abs(x) >= 1.0e-3_rp .and. abs(x) < 1.0e7_rp) then
        write(fmt, '(a,i0,a)') '(f0.', d, ')'
      else
        if (abs(x) >= 1.0e100_rp .or. abs(x) < 1.0e-99_rp) then
          write(fmt, '(a,i0,a)') '(es30.', d, 'e3)'
        else
          write(fmt, '(a,i0,a)') '(es30.', d, ')'
        end if
      end if
      write(buf, fmt) x
      read(buf, *, iostat=ios) y
      if (ios == 0 .and. y == x) exit
    end do
    s = trim(adjustl(buf))
    if (s(1:1) == '.') s = '0'//s
    if (len(s) >= 2) then
      if (s(1:2) == '-.') s = '-0'//s(2:)
    end if
  end function real_short

  !> A real for a one-line message: six significant digits (es13.5e2),
  !> never glued to the text before it.
  function real_brief(x) result(s)
    real(rp), intent(in) :: x
    character(len=:), allocatable :: s
    s = real_edit(x, '(es13.5e2)')
  end function real_brief

  !> A count such as 2.2E+10 (or 11 when small), for messages.
  function count_text(x) result(s)
    real(rp), intent(in) :: x
    character(:), allocatable :: s
    character(32) :: buf
    if (x < 1.0e7_rp) then
      write(buf, '(i0)') nint(x)
    else if (x < 1.0e99_rp) then
      write(buf, '(es10.2e2)') x
    else
      buf = real_short(x)
    end if
    s = trim(adjustl(buf))
  end function count_text

  !> Bytes as GB/MB with three digits, for messages.
  function bytes_text(x) result(s)
    real(rp), intent(in) :: x
    character(:), allocatable :: s
    character(32) :: buf
    if (x >= 1.0e12_rp) then
      buf = count_text(x/1.0e12_rp)//' TB'
      if (x < 1.0e19_rp) write(buf, '(f0.1,a)') x/1.0e12_rp, ' TB'
    else if (x >= 1.0e9_rp) then
      write(buf, '(f0.1,a)') x/1.0e9_rp, ' GB'
    else
      write(buf, '(f0.1,a)') x/1.0e6_rp, ' MB'
    end if
    s = trim(adjustl(buf))
  end function bytes_text

  !> A power of ten as 1e8.
  function pow10_text(x) result(s)
    real(rp), intent(in) :: x
    character(:), allocatable :: s
    character(16) :: buf
    write(buf, '(a,i0)') '1e', nint(log10(x))
    s = trim(buf)
  end function pow10_text

  !> Bytes as KB with one decimal.
  function kb_text(bytes) result(s)
    real(rp), intent(in) :: bytes
    character(:), allocatable :: s
    character(16) :: buf
    write(buf, '(f0.1)') bytes/1000.0_rp
    s = trim(buf)
  end function kb_text

end module strings
