! SPDX-License-Identifier: BSD-2-Clause
!> The checks of one key's value, shared by the groups' checks (modules
!> input_checks, input_contact_checks): a choice among the key table's
!> allowed words, an integer's lower bound, a real's range from the key
!> table, > 0, >= 0. Each message names the group, the key and the value.
!> No MPI, no PETSc.
module input_bounds
  use kinds, only: rp
  use input_keys, only: keys, key_index
  use input_text, only: item_end
  use strings, only: real_short
  implicit none
  private
  public :: choices, check_choice, need_int_ge, need_in_range, need_positive, need_nonnegative

contains

  !> The allowed values of choice key `key` (the key table's list; its order
  !> is the order of the codes in module config).
  function choices(key) result(s)
    character(*), intent(in) :: key
    character(:), allocatable :: s
    s = trim(keys(key_index(key))%allowed)
  end function choices

  !> value (lower case) must be one of the comma-separated `allowed`; code = its position.
  subroutine check_choice(group, key, value, allowed, code, ierr, msg)
    character(*), intent(in) :: group, key, value, allowed
    integer, intent(out) :: code, ierr
    character(*), intent(out) :: msg
    integer :: p, q, n
    ierr = 0
    msg = ''
    code = 0
    n = 0
    p = 1
    do while (p <= len(allowed))
      q = item_end(allowed, p, ',')
      n = n + 1
      if (trim(adjustl(allowed(p:q - 1))) == trim(value)) then
        code = n
        return
      end if
      p = q + 1
    end do
    ierr = 1
    msg = 'input: &'//group//': '//key//" = '"//trim(value)//"' is not one of "//allowed
  end subroutine check_choice

  subroutine need_int_ge(group, key, value, lo, ierr, msg)
    character(*), intent(in) :: group, key
    integer, intent(in) :: value, lo
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(16) :: a, b
    ierr = 0
    msg = ''
    if (value < lo) then
      ierr = 1
      write(a, '(i0)') value
      write(b, '(i0)') lo
      msg = 'input: &'//group//': '//key//' = '//trim(a)//' must be >= '//trim(b)
    end if
  end subroutine need_int_ge

  !> value within the bounds of key's `allowed` in the key table ('>= A',
  !> '> A', '<= B', '< B', separated by ', '); NaN fails too. The message
  !> gives the range as the table (and input/README.md) writes it.
  subroutine need_in_range(group, key, value, ierr, msg)
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: value
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: allowed, part
    real(rp) :: bound
    integer :: p, q, ios, w
    logical :: ok

    ierr = 0
    msg = ''
    allowed = trim(keys(key_index(key))%allowed)
    ok = value == value
    p = 1
    do while (p <= len(allowed) .and. ok)
      q = item_end(allowed, p, ', ')
      part = allowed(p:q - 1)
      w = merge(2, 1, part(2:2) == '=')
      read(part(w + 1:), *, iostat=ios) bound
      if (ios /= 0) part = '?'
      select case (part(1:w))
      case ('>=');  ok = value >= bound
      case ('>');   ok = value > bound
      case ('<=');  ok = value <= bound
      case ('<');   ok = value < bound
      case default
        ierr = 1
        msg = 'input: the key table''s range of '//key//' is not bounds: '//allowed   ! (test_input_text)
        return
      end select
      p = q + 2
    end do
    if (.not. ok) then
      ierr = 1
      msg = 'input: &'//group//': '//key//' = '//real_short(value)//' must be '//allowed// &
            ' (input/README.md, &'//group//')'
    end if
  end subroutine need_in_range

  !> value > 0 (NaN fails too).
  subroutine need_positive(group, key, value, ierr, msg)
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: value
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    if (.not. (value > 0.0_rp .and. value <= huge(value))) then
      ierr = 1
      msg = 'input: &'//group//': '//key//' = '//real_short(value)//' must be > 0'
    end if
  end subroutine need_positive

  !> value >= 0 (NaN fails too).
  subroutine need_nonnegative(group, key, value, ierr, msg)
    character(*), intent(in) :: group, key
    real(rp), intent(in) :: value
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    if (.not. (value >= 0.0_rp .and. value <= huge(value))) then
      ierr = 1
      msg = 'input: &'//group//': '//key//' = '//real_short(value)//' must be >= 0'
    end if
  end subroutine need_nonnegative

end module input_bounds
