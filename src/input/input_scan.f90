! SPDX-License-Identifier: BSD-2-Clause
!> The input file made ready for the namelist reader (module input): comments
!> and text outside groups blanked, unknown, repeated and unclosed groups
!> refused by line, each group's body kept apart to name a bad assignment.
!> No MPI, no PETSc.
module input_scan
  use input_keys, only: n_groups, group_names, G_SCENE
  use input_text, only: lower, is_name_char
  use strings, only: itoa
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

  !> scan_text's walk through the text: where it is, what it has made of
  !> the text so far, and its refusal.
  type :: scanner
    character(:), allocatable :: text     !< the input file
    integer :: i = 1                      !< the character at hand, text(i:i)
    character(:), allocatable :: clean    !< the text for the reader, line feeds kept
    integer :: nc = 0                     !< characters of clean in use
    character(:), allocatable :: bodies   !< group g's body at (g-1)*cap + 1 ...
    integer :: cap = 0                    !< room of clean and of each body [characters]
    integer :: blen(n_groups) = 0         !< characters of each body in use
    integer :: count(n_groups) = 0        !< times each group appeared
    integer :: cur = 0                    !< the group the scan is in; 0: outside every group
    integer :: first = 1                  !< the text's first character (after a byte-order mark)
    integer :: line_no = 1                !< the line of the character at hand
    integer :: group_start_line = 0       !< the line of the current group's &name
    logical :: in_comment = .false.
    character(1) :: quote = ' '           !< the open string's quote; ' ': none (only tracked in groups)
    character(:), allocatable :: refusal  !< why the text is refused; '' while it is not
  end type scanner

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
    type(scanner) :: s
    integer :: g

    call scanner_init(s, text)
    do while (s%i <= len(text) .and. len(s%refusal) == 0)
      call scan_at(s)
    end do
    if (len(s%refusal) == 0 .and. s%quote /= ' ') then
      s%refusal = 'input: &'//trim(group_names(s%cur))//': unterminated string'
    else if (len(s%refusal) == 0 .and. s%cur > 0) then
      s%refusal = 'input: &'//trim(group_names(s%cur))//' (line '//itoa(s%group_start_line)//') has no closing /'
    end if
    ierr = merge(1, 0, len(s%refusal) > 0)
    msg = s%refusal
    if (ierr /= 0) return
    pt%count = s%count
    call split_lines(s%clean(1:s%nc), pt%lines)
    allocate(character(max(1, maxval(s%blen))) :: pt%body(n_groups))
    pt%body = ''
    do g = 1, n_groups
      if (s%blen(g) > 0) pt%body(g) = s%bodies((g - 1)*s%cap + 1:(g - 1)*s%cap + s%blen(g))
    end do
  end subroutine scan_text

  !> A scanner at the start of text: room for the reader's text and the
  !> bodies, a UTF-8 byte-order mark (some editors write one) skipped.
  subroutine scanner_init(s, text)
    type(scanner), intent(out) :: s
    character(*), intent(in) :: text
    s%text = text
    s%refusal = ''
    ! Every rename adds 5 characters to a key of at least 6 (with its '='): room enough.
    s%cap = 2*len(text) + 16
    allocate(character(s%cap) :: s%clean)
    allocate(character(n_groups*s%cap) :: s%bodies)
    ! The mark's bytes by value: achar of them is outside ASCII.
    if (len(text) >= 3) then
      if (ichar(text(1:1)) == 239 .and. ichar(text(2:2)) == 187 .and. ichar(text(3:3)) == 191) s%first = 4
    end if
    s%i = s%first
  end subroutine scanner_init

  !> The character at hand: line ends, comments and strings first, then by
  !> whether the scan is in a group; the scan moves past what it took.
  subroutine scan_at(s)
    type(scanner), intent(inout) :: s
    character(1) :: c

    c = s%text(s%i:s%i)
    if (c == achar(13) .or. c == achar(9)) c = ' '
    if (c == achar(10)) then
      call emit(s, achar(10))
      s%in_comment = .false.
      s%line_no = s%line_no + 1
      call add_body(s, ' ')
      s%i = s%i + 1
    else if (s%in_comment) then
      s%i = s%i + 1
    else if (s%quote /= ' ') then
      ! Inside a string: copy; a doubled quote reopens at once.
      call emit(s, c)
      call add_body(s, c)
      if (c == s%quote) s%quote = ' '
      s%i = s%i + 1
    else if (c == '!') then
      s%in_comment = .true.
      s%i = s%i + 1
    else if (s%cur == 0) then
      call scan_outside(s, c)
    else
      call scan_inside(s, c)
    end if
  end subroutine scan_at

  !> Outside a group: a group starts with &name (or $name) at the start of
  !> a line or after a blank; anything else but blanks is refused, so that a
  !> truncated, misspelt or wrong file does not run the defaults silently.
  subroutine scan_outside(s, c)
    type(scanner), intent(inout) :: s
    character(1), intent(in) :: c
    logical :: at_word_start
    character(64) :: name
    integer :: k

    at_word_start = s%i == s%first
    if (s%i > s%first) at_word_start = index(' /'//achar(9)//achar(10)//achar(13), s%text(s%i - 1:s%i - 1)) > 0
    if ((c == '&' .or. c == '$') .and. at_word_start) then
      call get_name(s%text, s%i + 1, name, k)
      if (len_trim(name) > 0 .and. .not. (name(1:1) >= '0' .and. name(1:1) <= '9')) then
        call open_group(s, name)
        s%i = k
        return
      end if
    end if
    if (c /= ' ') then
      k = min(len(s%text), s%i + 23)
      if (index(s%text(s%i:k), achar(10)) > 0) k = s%i + index(s%text(s%i:k), achar(10)) - 2
      s%refusal = 'input: line '//itoa(s%line_no)//": text outside a namelist group: '"// &
        trim(printable(s%text(s%i:k)))//"' (only &group ... / and ! comments are allowed)"
      return
    end if
    s%i = s%i + 1
  end subroutine scan_outside

  !> &name starts group `name`: a known group, not seen before.
  subroutine open_group(s, name)
    type(scanner), intent(inout) :: s
    character(*), intent(in) :: name
    integer :: g

    g = group_index(name)
    if (g == 0) then
      s%refusal = 'input: line '//itoa(s%line_no)//': unknown namelist group &'//trim(name)// &
        ' (groups: &lattice, &material, &scene, &time, &output, &identify, &control)'
      return
    end if
    s%count(g) = s%count(g) + 1
    if (s%count(g) > 1) then
      s%refusal = 'input: &'//trim(group_names(g))//' appears again at line '//itoa(s%line_no)// &
        ': each group may appear at most once'
      return
    end if
    s%cur = g
    s%group_start_line = s%line_no
    call emit(s, '&'//trim(group_names(g))//' ')
  end subroutine open_group

  !> Inside a group: '/' (or the old-style &end) closes it, another & or $
  !> is a group left open; the key `scene` of &scene is renamed; the rest is
  !> copied to the reader's text and the group's body.
  subroutine scan_inside(s, c)
    type(scanner), intent(inout) :: s
    character(1), intent(in) :: c
    character(64) :: name
    integer :: k

    if (c == '/') then
      call emit(s, '/')
      s%cur = 0
      s%i = s%i + 1
    else if (c == '&' .or. c == '$') then
      call get_name(s%text, s%i + 1, name, k)
      if (trim(name) /= 'end') then
        s%refusal = 'input: &'//trim(group_names(s%cur))//' (line '//itoa(s%group_start_line)// &
          ') has no closing / before the '//c//' at line '//itoa(s%line_no)
        return
      end if
      ! Old-style terminator &end: hand the reader a plain '/'.
      call emit(s, '/')
      s%cur = 0
      s%i = k
    else if (s%cur == G_SCENE .and. is_name_char(c)) then
      ! A whole name: copy it at once, renaming the key `scene`.
      call get_name(s%text, s%i, name, k)
      if (trim(name) == 'scene' .and. followed_by_equals(s%text, k)) then
        call emit(s, 'scene_name')
        call add_body(s, 'scene_name')
      else
        call emit(s, s%text(s%i:k - 1))
        call add_body(s, s%text(s%i:k - 1))
      end if
      s%i = k
    else
      if (c == "'" .or. c == '"') s%quote = c
      call emit(s, c)
      call add_body(s, c)
      s%i = s%i + 1
    end if
  end subroutine scan_inside

  !> The reader's text as records, one a line.
  subroutine split_lines(clean, lines)
    character(*), intent(in) :: clean
    character(:), allocatable, intent(out) :: lines(:)
    integer :: i, k, nlines, maxlen, line_start

    nlines = 1
    maxlen = 1
    line_start = 1
    do i = 1, len(clean)
      if (clean(i:i) == achar(10)) then
        maxlen = max(maxlen, i - line_start)
        nlines = nlines + 1
        line_start = i + 1
      end if
    end do
    maxlen = max(maxlen, len(clean) - line_start + 1)
    allocate(character(maxlen) :: lines(nlines))
    lines = ''
    k = 1
    line_start = 1
    do i = 1, len(clean)
      if (clean(i:i) == achar(10)) then
        if (i > line_start) lines(k) = clean(line_start:i - 1)
        k = k + 1
        line_start = i + 1
      end if
    end do
    if (len(clean) >= line_start) lines(k) = clean(line_start:)
  end subroutine split_lines

  !> str appended to the reader's text.
  subroutine emit(s, str)
    type(scanner), intent(inout) :: s
    character(*), intent(in) :: str
    s%clean(s%nc + 1:s%nc + len(str)) = str
    s%nc = s%nc + len(str)
  end subroutine emit

  !> str appended to the current group's body (none outside a group).
  subroutine add_body(s, str)
    type(scanner), intent(inout) :: s
    character(*), intent(in) :: str
    integer :: at
    if (s%cur == 0) return
    at = (s%cur - 1)*s%cap + s%blen(s%cur)
    s%bodies(at + 1:at + len(str)) = str
    s%blen(s%cur) = s%blen(s%cur) + len(str)
  end subroutine add_body

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
