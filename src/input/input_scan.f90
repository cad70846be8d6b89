! SPDX-License-Identifier: BSD-2-Clause
!> The input file made ready for the namelist reader (module input): comments
!> and text outside groups blanked, unknown, repeated and unclosed groups
!> refused by line, each group's body kept apart to name a bad assignment.
!> No MPI, no PETSc.
module input_scan
  use input_keys, only: n_groups, group_names, G_SCENE
  use input_text, only: lower, is_name_char
  implicit none
  private
  public :: parsed_text, scan_text, group_index

  !> The input text made ready for the namelist reader: comments and text
  !> outside groups blanked, one record per line; each group's body kept
  !> apart to locate a bad assignment.
  type :: parsed_text
    character(:), allocatable :: lines(:)
    integer :: count(n_groups) = 0
    character(:), allocatable :: body(:)
  end type parsed_text

contains


  !> Blank comments and text outside groups, count the groups, keep each
  !> group's body; reject unknown, repeated and unclosed groups. The key
  !> `scene` of group &scene is renamed `scene_name` on the way: Fortran does
  !> not let a namelist group and one of its objects share a name.
  subroutine scan_text(text, pt, ierr, msg)
    character(*), intent(in) :: text
    type(parsed_text), intent(out) :: pt
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: clean
    character(:), allocatable :: bodies      ! group g's body at (g-1)*cap + 1 ...
    integer :: blen(n_groups), cap
    character(1) :: c, quote
    character(64) :: name
    logical :: in_group, in_comment, at_word_start
    integer :: i, k, n, nc, g, nlines, maxlen, line_start, cur, group_start_line, line_no
    integer :: first                         ! the first character of the text (after a byte-order mark)

    ierr = 0
    msg = ''
    n = len(text)
    ! Every rename adds 5 characters to a key of at least 6 (with its '='): room enough.
    cap = 2*n + 16
    allocate(character(cap) :: clean)
    allocate(character(n_groups*cap) :: bodies)
    nc = 0
    blen = 0
    in_group = .false.
    in_comment = .false.
    quote = ' '
    cur = 0
    line_no = 1
    group_start_line = 0
    i = 1
    ! A UTF-8 byte-order mark (some editors write one) is not text (the
    ! bytes by value: achar of them is outside ASCII).
    if (n >= 3) then
      if (ichar(text(1:1)) == 239 .and. ichar(text(2:2)) == 187 .and. ichar(text(3:3)) == 191) i = 4
    end if
    first = i
    do while (i <= n)
      c = text(i:i)
      if (c == achar(13) .or. c == achar(9)) c = ' '
      if (c == achar(10)) then
        call emit(achar(10))
        in_comment = .false.
        line_no = line_no + 1
        if (cur > 0) call add_body(' ')
        i = i + 1
        cycle
      end if
      if (in_comment) then
        i = i + 1
        cycle
      end if
      if (quote /= ' ') then
        ! Inside a string (only tracked in groups): copy; a doubled quote reopens at once.
        call emit(c)
        call add_body(c)
        if (c == quote) quote = ' '
        i = i + 1
        cycle
      end if
      if (c == '!') then
        in_comment = .true.
        i = i + 1
        cycle
      end if
      if (.not. in_group) then
        ! A group starts with &name (or $name) at the start of a line or after a blank.
        at_word_start = i == first
        if (i > first) at_word_start = index(' /'//achar(9)//achar(10)//achar(13), text(i - 1:i - 1)) > 0
        if ((c == '&' .or. c == '$') .and. at_word_start) then
          call get_name(text, i + 1, name, k)
          if (len_trim(name) > 0 .and. .not. (name(1:1) >= '0' .and. name(1:1) <= '9')) then
            g = group_index(name)
            if (g == 0) then
              ierr = 1
              write(msg, '(a,i0,a)') 'input: line ', line_no, ': unknown namelist group &'//trim(name)// &
                ' (groups: &lattice, &material, &scene, &time, &output, &identify, &control)'
              return
            end if
            pt%count(g) = pt%count(g) + 1
            if (pt%count(g) > 1) then
              ierr = 1
              write(msg, '(a,i0,a)') 'input: &'//trim(group_names(g))//' appears again at line ', &
                line_no, ': each group may appear at most once'
              return
            end if
            in_group = .true.
            group_start_line = line_no
            cur = g
            call emit('&'//trim(group_names(g))//' ')
            i = k
            cycle
          end if
        end if
        ! Anything but blanks and comments outside a group is an error: a
        ! truncated, misspelt or wrong file must not run the defaults silently.
        if (c /= ' ') then
          ierr = 1
          k = min(n, i + 23)
          if (index(text(i:k), achar(10)) > 0) k = i + index(text(i:k), achar(10)) - 2
          write(msg, '(a,i0,a)') 'input: line ', line_no, ": text outside a namelist group: '"// &
            trim(printable(text(i:k)))//"' (only &group ... / and ! comments are allowed)"
          return
        end if
        i = i + 1
        cycle
      end if
      ! Inside a group.
      if (c == '/') then
        call emit('/')
        in_group = .false.
        cur = 0
        i = i + 1
        cycle
      end if
      if (c == '&' .or. c == '$') then
        call get_name(text, i + 1, name, k)
        if (trim(name) == 'end') then
          ! Old-style terminator &end: hand the reader a plain '/'.
          call emit('/')
          in_group = .false.
          cur = 0
          i = k
          cycle
        end if
        ierr = 1
        write(msg, '(a,i0,a,i0)') 'input: &'//trim(group_names(cur))//' (line ', group_start_line, &
          ') has no closing / before the '//c//' at line ', line_no
        return
      end if
      if (c == "'" .or. c == '"') quote = c
      if (cur == G_SCENE .and. is_name_char(c)) then
        ! A whole name: copy it at once, renaming the key `scene`.
        call get_name(text, i, name, k)
        if (trim(name) == 'scene' .and. followed_by_equals(text, k)) then
          call emit('scene_name')
          call add_body_str('scene_name')
        else
          call emit(text(i:k - 1))
          call add_body_str(text(i:k - 1))
        end if
        i = k
        cycle
      end if
      call emit(c)
      call add_body(c)
      i = i + 1
    end do
    if (quote /= ' ') then
      ierr = 1
      msg = 'input: &'//trim(group_names(cur))//': unterminated string'
      return
    end if
    if (in_group) then
      ierr = 1
      write(msg, '(a,i0,a)') 'input: &'//trim(group_names(cur))//' (line ', group_start_line, &
        ') has no closing /'
      return
    end if

    ! Split into records, one per line.
    nlines = 1
    maxlen = 1
    line_start = 1
    do i = 1, nc
      if (clean(i:i) == achar(10)) then
        maxlen = max(maxlen, i - line_start)
        nlines = nlines + 1
        line_start = i + 1
      end if
    end do
    maxlen = max(maxlen, nc - line_start + 1)
    allocate(character(maxlen) :: pt%lines(nlines))
    pt%lines = ''
    k = 1
    line_start = 1
    do i = 1, nc
      if (clean(i:i) == achar(10)) then
        if (i > line_start) pt%lines(k) = clean(line_start:i - 1)
        k = k + 1
        line_start = i + 1
      end if
    end do
    if (nc >= line_start) pt%lines(k) = clean(line_start:nc)
    allocate(character(max(1, maxval(blen))) :: pt%body(n_groups))
    pt%body = ''
    do g = 1, n_groups
      if (blen(g) > 0) pt%body(g) = bodies((g - 1)*cap + 1:(g - 1)*cap + blen(g))
    end do

  contains

    subroutine emit(str)
      character(*), intent(in) :: str
      clean(nc + 1:nc + len(str)) = str
      nc = nc + len(str)
    end subroutine emit

    subroutine add_body(ch)
      character(1), intent(in) :: ch
      if (cur == 0) return
      blen(cur) = blen(cur) + 1
      bodies((cur - 1)*cap + blen(cur):(cur - 1)*cap + blen(cur)) = ch
    end subroutine add_body

    subroutine add_body_str(str)
      character(*), intent(in) :: str
      if (cur == 0) return
      bodies((cur - 1)*cap + blen(cur) + 1:(cur - 1)*cap + blen(cur) + len(str)) = str
      blen(cur) = blen(cur) + len(str)
    end subroutine add_body_str

  end subroutine scan_text

  !> Whether text(k:) is blanks, optional subscripts, then '='.
  logical function followed_by_equals(text, k)
    character(*), intent(in) :: text
    integer, intent(in) :: k
    integer :: j
    followed_by_equals = .false.
    j = k
    do while (j <= len(text))
      if (text(j:j) /= ' ' .and. text(j:j) /= achar(9) .and. text(j:j) /= achar(10) .and. &
          text(j:j) /= achar(13)) exit
      j = j + 1
    end do
    if (j <= len(text)) followed_by_equals = text(j:j) == '='
  end function followed_by_equals

  !> Identifier starting at text(i:); k: first position after it.
  subroutine get_name(text, i, name, k)
    character(*), intent(in) :: text
    integer, intent(in) :: i
    character(*), intent(out) :: name
    integer, intent(out) :: k
    name = ''
    k = i
    do while (k <= len(text))
      if (.not. is_name_char(text(k:k))) exit
      k = k + 1
    end do
    if (k > i) name = lower(text(i:min(k - 1, i + len(name) - 1)))
  end subroutine get_name

  integer function group_index(name)
    character(*), intent(in) :: name
    integer :: g
    group_index = 0
    do g = 1, n_groups
      if (trim(name) == trim(group_names(g))) group_index = g
    end do
  end function group_index

  !> s with every byte that is not printable ASCII shown as '?' (garbage
  !> input must not put control characters into the error line).
  pure function printable(s) result(r)
    character(*), intent(in) :: s
    character(len(s)) :: r
    integer :: i, c
    r = s
    do i = 1, len(s)
      c = iachar(s(i:i))
      if (c < 32 .or. c > 126) r(i:i) = '?'
    end do
  end function printable

end module input_scan
