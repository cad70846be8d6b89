! SPDX-License-Identifier: BSD-2-Clause
!> The input's text below the namelist reader, without MPI or PETSc
!> (unit-tested alone: tests/unit/test_input_text.f90):
!> - the lookup of a key in the table of keys (module input_keys: names are
!>   unique across groups);
!> - the check of a value against its key's type, so that `nx = 33.5` is
!>   refused as "expected an integer" instead of the reader's "Cannot match
!>   namelist object name .5", and an unquoted string gets the hint to quote it;
!> - the lexer of -nuno_set's assignments: keys separated by commas or
!>   blanks (both accepted: `nx=13 ny=13` is two keys), an empty value, a
!>   `/` or `!` outside a string, an unknown key and a key given twice each
!>   refused by name, several -nuno_set options read in order as one list;
!> - the -nuno_set options of the command line, read from the arguments
!>   themselves: PETSc's options database keeps only the last of a repeated
!>   option, and from Fortran it keeps a value only up to its first blank.
module input_text
  use strings, only: itoa
  use input_keys, only: keys, key_index, KEY_INTEGER, KEY_REAL, KEY_LOGICAL, KEY_STRING
  implicit none
  private
  public :: assignment_t, lex_overrides, key_lookup, value_error, command_line_overrides, key_default
  public :: namelist_value
  public :: next_assignment, is_name_char, lower, strip_commas, overrides_record, assignment_lhs, item_end
  public :: KEY_INTEGER, KEY_REAL, KEY_LOGICAL, KEY_STRING

  !> The separator of the -nuno_set options joined into one text
  !> (command_line_overrides): a line feed, a hard boundary for lex_overrides.
  character(1), parameter :: option_sep = achar(10)

  !> One key = value of -nuno_set.
  type :: assignment_t
    character(:), allocatable :: group   !< the key's namelist group ('lattice', ...)
    character(:), allocatable :: key     !< lower case, without blanks and group%: 'nx', 'gravity(3)'
    character(:), allocatable :: base    !< the key without subscript: 'gravity'
    character(:), allocatable :: value   !< the value as written, blanks and end commas trimmed
    character(:), allocatable :: text    !< the assignment as written, for messages
  end type assignment_t

contains

  !> The group, type (KEY_*) and array-ness of key `name` (lower case, no
  !> subscript); group = '' and kind = 0 when there is no such key.
  subroutine key_lookup(name, group, kind, array)
    character(*), intent(in) :: name
    character(*), intent(out) :: group
    integer, intent(out) :: kind
    logical, intent(out) :: array
    integer :: k
    group = ''
    kind = 0
    array = .false.
    k = key_index(name)
    if (k == 0) return
    group = keys(k)%group
    kind = keys(k)%kind
    array = keys(k)%size > 1
  end subroutine key_lookup

  !> The key table's default of key k (an index into input_keys' keys) in
  !> scene `scene`, in namelist syntax: the plain default or the one after
  !> "; SCENE ", `<scene>` replaced by the scene's name, an array's
  !> parentheses dropped; '' when the default is a description ("(required)",
  !> "from the scene (see above)"), which leaves the configuration's own
  !> initial value (module config).
  function key_default(k, scene) result(v)
    integer, intent(in) :: k
    character(*), intent(in) :: scene
    character(:), allocatable :: v, d, part
    integer :: p, q, b
    d = trim(keys(k)%default)
    p = item_end(d, 1, '; ')
    v = d(1:p - 1)
    do while (p <= len(d))
      q = item_end(d, p + 2, '; ')
      part = d(p + 2:q - 1)
      b = index(part, ' ')
      if (b > 0) then
        if (part(1:b - 1) == scene) v = part(b + 1:)
      end if
      p = q
    end do
    b = index(v, '<scene>')
    if (b > 0) v = v(1:b - 1)//scene//v(b + 7:)
    if (len(v) >= 2) then
      if (v(1:1) == '(' .and. v(len(v):len(v)) == ')') v = v(2:len(v) - 1)
    end if
    if (len(value_error(trim(keys(k)%name), v)) > 0) v = ''
  end function key_default

  !> The value text of key `name` (lower case) in a namelist WRITE of its
  !> group (NAME=value records, an array's values possibly continued on the
  !> next records, as module input's input_namelist_dump gives them, joined
  !> by line feeds); '' when the key is not there.
  function namelist_value(dump, name) result(v)
    character(*), intent(in) :: dump, name
    character(:), allocatable :: v, rec
    integer :: p, q, e
    logical :: inside
    v = ''
    inside = .false.
    p = 1
    do while (p <= len(dump))
      q = item_end(dump, p, achar(10))
      rec = trim(adjustl(dump(p:q - 1)))
      p = q + 1
      e = index(rec, '=')
      if (e > 1) then
        if (verify(rec(1:e - 1), 'ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_') == 0) then
          if (inside) return
          inside = lower(rec(1:e - 1)) == name
          if (inside) v = trim(adjustl(rec(e + 1:)))
          cycle
        end if
      end if
      if (len(rec) == 0) cycle
      if (rec(1:1) == '/' .or. rec(1:1) == '&') then
        if (inside) return
        cycle
      end if
      if (inside) v = v//' '//rec
    end do
  end function namelist_value

  !> Why `value` cannot be the value of key `key` ('gravity', 'nx', ...; a
  !> subscript is allowed), or '' when it can. The value is namelist syntax:
  !> items separated by commas or blanks, `r*value` repeats, strings quoted
  !> (a doubled quote inside). A key that is not in the table gives ''.
  function value_error(key, value) result(msg)
    character(*), intent(in) :: key, value
    character(:), allocatable :: msg
    character(8) :: group
    character(:), allocatable :: base, item
    integer :: kind, i, n, nitems
    logical :: array, subscripted

    msg = ''
    base = lower(trim(adjustl(key)))
    subscripted = index(base, '(') > 0
    if (subscripted) base = base(1:index(base, '(') - 1)
    call key_lookup(base, group, kind, array)
    if (kind == 0) return
    n = len_trim(value)
    if (n == 0) then
      msg = 'no value'
      return
    end if
    if (kind == KEY_STRING .and. verify(value(1:1), '''"') /= 0) then
      msg = "a string must be quoted: "//trim(key)//"='"//trim(adjustl(value))//"'"
      return
    end if
    nitems = 0
    i = 1
    do while (i <= n)
      if (value(i:i) == ' ' .or. value(i:i) == ',') then
        i = i + 1
        cycle
      end if
      call next_item(value(1:n), i, item, msg)
      if (len(msg) > 0) return
      nitems = nitems + 1
      msg = item_error(item, kind, array)
      if (len(msg) > 0) return
    end do
    if (nitems == 0) then
      msg = 'no value'
    else if (nitems > 1 .and. .not. array) then
      msg = 'expected one '//type_name(kind, .false.)//', got '//itoa(nitems)//' values'
      if (kind == KEY_STRING) msg = msg//" (a string with blanks or commas goes in one pair of quotes)"
    end if
  end function value_error

  !> The item of a value that starts at value(i:) (a quoted string, a doubled
  !> quote inside, or text up to a blank or comma); i moves past it. msg
  !> says why there is none: an unterminated string, or '/', '!', '&' or '$'
  !> outside a string, which would end the group or start a comment for the
  !> namelist reader, which then ignores the rest.
  subroutine next_item(value, i, item, msg)
    character(*), intent(in) :: value
    integer, intent(inout) :: i
    character(:), allocatable, intent(out) :: item, msg
    character(1) :: quote
    integer :: start, n

    msg = ''
    item = ''
    n = len(value)
    start = i
    quote = ' '
    do while (i <= n)
      if (quote /= ' ') then
        if (value(i:i) == quote) then
          if (i < n) then
            if (value(i + 1:i + 1) == quote) then
              i = i + 2
              cycle
            end if
          end if
          quote = ' '
        end if
      else if (value(i:i) == "'" .or. value(i:i) == '"') then
        quote = value(i:i)
      else if (value(i:i) == ' ' .or. value(i:i) == ',') then
        exit
      else if (value(i:i) == '/' .or. value(i:i) == '!' .or. value(i:i) == '&' .or. value(i:i) == '$') then
        msg = "'"//value(i:i)//"' outside a string is not part of a value (the namelist reader would drop "// &
              "what follows it)"
        return
      end if
      i = i + 1
    end do
    if (quote /= ' ') then
      msg = 'unterminated string'
      return
    end if
    item = value(start:i - 1)
  end subroutine next_item

  !> Why `item`, one item of a value, is not of type kind (array: the key
  !> is an array, which may take a repeat count r*), or '' when it is.
  function item_error(item, kind, array) result(msg)
    character(*), intent(in) :: item
    integer, intent(in) :: kind
    logical, intent(in) :: array
    character(:), allocatable :: msg, one
    integer :: star

    msg = ''
    one = item
    ! A repeat count r*: the value after it (or none: r null values).
    star = index(item, '*')
    if (star > 1 .and. verify(item(1:max(1, star - 1)), '0123456789') == 0 .and. &
        verify(item(1:1), '''"') /= 0) then
      if (.not. array) then
        msg = 'expected one '//type_name(kind, .false.)//' (a repeat count '//item(1:star)//' is for arrays)'
        return
      end if
      one = item(star + 1:)
      if (len(one) == 0) return
    end if
    if (.not. item_ok(kind, one)) then
      msg = 'expected '//type_name(kind, .true.)
      if (kind == KEY_STRING) msg = msg//' (one string in quotes)'
    end if
  end function item_error

  !> Whether one item (no repeat count) is a value of type kind.
  logical function item_ok(kind, s) result(ok)
    integer, intent(in) :: kind
    character(*), intent(in) :: s
    character(:), allocatable :: l
    l = lower(s)
    select case (kind)
    case (KEY_INTEGER)
      ok = is_integer(s)
    case (KEY_REAL)
      ok = is_real(s)
    case (KEY_LOGICAL)
      select case (l)
      case ('t', 'f', '.t', '.f', '.t.', '.f.', 'true', 'false', '.true.', '.false.')
        ok = .true.
      case default
        ok = .false.
      end select
    case (KEY_STRING)
      ok = len(s) >= 2
      if (ok) ok = verify(s(1:1), '''"') == 0 .and. s(len(s):len(s)) == s(1:1)
    case default
      ok = .false.
    end select
  end function item_ok

  !> An optionally signed string of digits.
  logical function is_integer(s)
    character(*), intent(in) :: s
    integer :: i
    i = 1
    if (len(s) > 0) then
      if (s(1:1) == '+' .or. s(1:1) == '-') i = 2
    end if
    is_integer = len(s) >= i .and. verify(s(i:), '0123456789') == 0
  end function is_integer

  !> A real literal as the namelist reader takes it: [sign] digits with at
  !> most one point, at least one digit, then an optional exponent letter
  !> (e, d, q) with [sign] digits; or Inf, Infinity, NaN (refused later by
  !> the finiteness check, which names them).
  logical function is_real(s)
    character(*), intent(in) :: s
    character(:), allocatable :: l
    integer :: i, n, ndig, e
    is_real = .false.
    l = lower(s)
    n = len(l)
    i = 1
    if (n > 0) then
      if (l(1:1) == '+' .or. l(1:1) == '-') i = 2
    end if
    if (i <= n) then
      if (l(i:) == 'inf' .or. l(i:) == 'infinity' .or. l(i:) == 'nan') then
        is_real = .true.
        return
      end if
    end if
    ndig = 0
    do while (i <= n)
      if (verify(l(i:i), '0123456789') /= 0) exit
      ndig = ndig + 1
      i = i + 1
    end do
    if (i <= n) then
      if (l(i:i) == '.') then
        i = i + 1
        do while (i <= n)
          if (verify(l(i:i), '0123456789') /= 0) exit
          ndig = ndig + 1
          i = i + 1
        end do
      end if
    end if
    if (ndig == 0) return
    if (i > n) then
      is_real = .true.
      return
    end if
    if (verify(l(i:i), 'edq') /= 0) return
    i = i + 1
    if (i > n) return
    if (l(i:i) == '+' .or. l(i:i) == '-') i = i + 1
    e = i
    if (e > n) return
    is_real = verify(l(e:), '0123456789') == 0
  end function is_real

  function type_name(kind, article) result(s)
    integer, intent(in) :: kind
    logical, intent(in) :: article
    character(:), allocatable :: s
    select case (kind)
    case (KEY_INTEGER)
      s = 'integer'
    case (KEY_REAL)
      s = 'real number'
    case (KEY_LOGICAL)
      s = 'logical (.true. or .false.)'
    case default
      s = 'quoted string'
    end select
    if (article) then
      if (kind == KEY_INTEGER) then
        s = 'an '//s
      else
        s = 'a '//s
      end if
    end if
  end function type_name

  !> The assignments of -nuno_set (ov: one option's value, or several
  !> joined by command_line_overrides), in order. Refused, with a one-line
  !> msg that names the key (ierr = 1): text that is not key=value, an
  !> unknown key or group, a subscript on a scalar key, a value that is
  !> empty or not of the key's type, a key given twice (also across
  !> options; an array's element and the whole array count as the same key).
  subroutine lex_overrides(ov, items, ierr, msg)
    character(*), intent(in) :: ov
    type(assignment_t), allocatable, intent(out) :: items(:)
    integer, intent(out) :: ierr
    character(:), allocatable, intent(out) :: msg
    integer :: first, last

    ierr = 0
    msg = ''
    allocate(items(0))
    first = 1
    do
      ! One option's value: up to the next separator.
      last = item_end(ov, first, option_sep) - 1
      call lex_option(ov(first:last), items, ierr, msg)
      if (ierr /= 0) return
      if (last >= len(ov)) exit
      first = last + 2
    end do
  end subroutine lex_overrides

  !> The assignments of one -nuno_set option's value `piece`, appended to
  !> items; text before the first "key =" is refused.
  subroutine lex_option(piece, items, ierr, msg)
    character(*), intent(in) :: piece
    type(assignment_t), allocatable, intent(inout) :: items(:)
    integer, intent(out) :: ierr
    character(:), allocatable, intent(inout) :: msg
    type(assignment_t) :: it
    integer :: n, p, q

    ierr = 0
    n = len_trim(piece)
    if (n == 0 .or. verify(piece, ' ,') == 0) then
      call refuse('-nuno_set has no value: expected key=value[,key=value...]', ierr, msg)
      return
    end if
    p = next_assignment(piece(1:n), 1)
    if (p > n) then
      call refuse("-nuno_set '"//piece(1:n)//"': expected key=value[,key=value...]", ierr, msg)
      return
    end if
    if (verify(piece(1:p - 1), ' ,') /= 0) then
      call refuse("-nuno_set '"//piece(1:n)//"': '"//trim(adjustl(piece(1:p - 1)))// &
                  "' is not key=value (keys are separated by commas or blanks)", ierr, msg)
      return
    end if
    do while (p <= n)
      q = next_assignment(piece(1:n), p + 1)
      call lex_assignment(strip_commas(piece(p:q - 1)), it, ierr, msg)
      if (ierr /= 0) return
      call check_given_once(items, it, ierr, msg)
      if (ierr /= 0) return
      call append(items, it)
      p = q
    end do
  end subroutine lex_option

  !> One assignment `a` ("key = value", "group%key(i) = value") of -nuno_set
  !> as `it`; refused: an unknown key or one of another group, a subscript
  !> on a scalar key, a value that is empty or not of the key's type.
  subroutine lex_assignment(a, it, ierr, msg)
    character(*), intent(in) :: a
    type(assignment_t), intent(out) :: it
    integer, intent(out) :: ierr
    character(:), allocatable, intent(inout) :: msg
    character(:), allocatable :: lhs, why, qual
    character(8) :: group
    integer :: k, kind
    logical :: array

    ierr = 0
    lhs = assignment_lhs(a)
    it%text = a
    it%value = strip_commas(a(index(a, '=') + 1:))
    ! group%key: the group must be the key's.
    qual = ''
    k = index(lhs, '%')
    if (k > 0) then
      qual = lhs(1:k - 1)
      lhs = lhs(k + 1:)
    end if
    it%key = lhs
    it%base = lhs
    if (index(lhs, '(') > 0) it%base = lhs(1:index(lhs, '(') - 1)
    call key_lookup(it%base, group, kind, array)
    if (kind == 0) then
      call refuse("-nuno_set: unknown key '"//it%key//"' (in: "//a//')', ierr, msg)
    else if (len(qual) > 0 .and. qual /= trim(group)) then
      call refuse("-nuno_set: '"//qual//'%'//it%key//"': "//it%base//' is a key of &'//trim(group)// &
                  ' (in: '//a//')', ierr, msg)
    else if (it%key /= it%base .and. .not. array) then
      call refuse('-nuno_set: '//it%base//' is not an array: no subscript (in: '//a//')', ierr, msg)
    else if (len(it%value) == 0) then
      call refuse('-nuno_set: '//it%key//' has no value (in: '//a//')', ierr, msg)
    end if
    if (ierr /= 0) return
    it%group = trim(group)
    why = value_error(it%key, it%value)
    if (len(why) > 0) then
      ! An unquoted string: the shell may have eaten the quotes.
      if (kind == KEY_STRING .and. verify(it%value(1:1), '''"') /= 0) &
        why = "a string must be quoted, the quotes protected from the shell: -nuno_set """// &
              it%key//"='"//it%value//"'"""
      call refuse('-nuno_set: '//it%key//'='//it%value//': '//why, ierr, msg)
    end if
  end subroutine lex_assignment

  !> A key given twice (also across options; an array's element and the
  !> whole array count as the same key) is refused.
  subroutine check_given_once(items, it, ierr, msg)
    type(assignment_t), intent(in) :: items(:), it
    integer, intent(out) :: ierr
    character(:), allocatable, intent(inout) :: msg
    integer :: k
    ierr = 0
    do k = 1, size(items)
      if (items(k)%base /= it%base) cycle
      if (items(k)%key == it%key .or. items(k)%key == items(k)%base .or. it%key == it%base) then
        call refuse('-nuno_set: '//it%key//' is given twice ('//items(k)%text//' and '//it%text// &
                    '): give each key once', ierr, msg)
        return
      end if
    end do
  end subroutine check_given_once

  !> it appended to items.
  subroutine append(items, it)
    type(assignment_t), allocatable, intent(inout) :: items(:)
    type(assignment_t), intent(in) :: it
    type(assignment_t), allocatable :: grown(:)
    allocate(grown(size(items) + 1))
    grown(1:size(items)) = items
    grown(size(items) + 1) = it
    call move_alloc(grown, items)
  end subroutine append

  !> A -nuno_set refusal: ierr = 1, msg the input's one line.
  subroutine refuse(text, ierr, msg)
    character(*), intent(in) :: text
    integer, intent(out) :: ierr
    character(:), allocatable, intent(inout) :: msg
    ierr = 1
    msg = 'input: '//text
  end subroutine refuse

  !> The values of every -nuno_set option of the command line, in order,
  !> joined by line feeds (lex_overrides reads each alone); count: how many.
  !> PETSc's options database is not used: it keeps only the last of a
  !> repeated option, and (from Fortran) a value only up to its first blank.
  !> A -nuno_set without a value gives an empty piece, which lex_overrides
  !> refuses.
  subroutine command_line_overrides(text, count)
    character(:), allocatable, intent(out) :: text
    integer, intent(out) :: count
    character(:), allocatable :: arg
    integer :: k, n, alen
    text = ''
    count = 0
    n = command_argument_count()
    k = 1
    do while (k <= n)
      call get_arg(k, arg)
      if (arg == '-nuno_set') then
        count = count + 1
        if (count > 1) text = text//option_sep
        if (k < n) then
          call get_arg(k + 1, arg)
          text = text//arg
          k = k + 1
        end if
      end if
      k = k + 1
    end do
  contains
    subroutine get_arg(i, s)
      integer, intent(in) :: i
      character(:), allocatable, intent(out) :: s
      call get_command_argument(i, length=alen)
      allocate(character(alen) :: s)
      if (alen > 0) call get_command_argument(i, s)
    end subroutine get_arg
  end subroutine command_line_overrides

  !> The -nuno_set options as a command line would give them, for the
  !> namelist text recorded in the output: "-nuno_set A -nuno_set B".
  function overrides_record(ov) result(r)
    character(*), intent(in) :: ov
    character(:), allocatable :: r
    integer :: p, q, n
    r = '-nuno_set '
    n = len_trim(ov)
    p = 1
    do
      q = item_end(ov(1:n), p, option_sep)
      r = r//ov(p:q - 1)
      if (q > n) exit
      r = r//' -nuno_set '
      p = q + 1
    end do
  end function overrides_record

  !> Position of the next "name =" (or "name(...) =") at or after `from`,
  !> outside strings; len(body)+1 when none.
  integer function next_assignment(body, from) result(p)
    character(*), intent(in) :: body
    integer, intent(in) :: from
    character(1) :: quote
    integer :: i, k, depth
    quote = ' '
    p = len(body) + 1
    do i = 1, len(body)
      if (quote /= ' ') then
        if (body(i:i) == quote) quote = ' '
        cycle
      end if
      if (body(i:i) == "'" .or. body(i:i) == '"') then
        quote = body(i:i)
        cycle
      end if
      if (i < from) cycle
      if (.not. is_name_char(body(i:i))) cycle
      if (i > 1) then
        if (is_name_char(body(i - 1:i - 1)) .or. body(i - 1:i - 1) == '%' .or. &
            body(i - 1:i - 1) == '.') cycle
      end if
      ! Name, optional subscripts and components, blanks, then '=' (not '==').
      k = i
      depth = 0
      do while (k <= len(body))
        if (depth > 0) then
          if (body(k:k) == '(') depth = depth + 1
          if (body(k:k) == ')') depth = depth - 1
        else if (body(k:k) == '(') then
          depth = 1
        else if (.not. (is_name_char(body(k:k)) .or. body(k:k) == '%')) then
          exit
        end if
        k = k + 1
      end do
      do while (k <= len(body))
        if (body(k:k) /= ' ') exit
        k = k + 1
      end do
      if (k <= len(body)) then
        if (body(k:k) == '=') then
          if (k == len(body)) then
            p = i
            return
          else if (body(k + 1:k + 1) /= '=') then
            p = i
            return
          end if
        end if
      end if
    end do
  end function next_assignment

  pure logical function is_name_char(c)
    character(1), intent(in) :: c
    is_name_char = (c >= 'a' .and. c <= 'z') .or. (c >= 'A' .and. c <= 'Z') .or. &
                   (c >= '0' .and. c <= '9') .or. c == '_'
  end function is_name_char

  !> The key side of an assignment "key = value": lower case, without blanks.
  function assignment_lhs(a) result(lhs)
    character(*), intent(in) :: a
    character(:), allocatable :: lhs
    integer :: k
    lhs = ''
    do k = 1, index(a, '=') - 1
      if (a(k:k) /= ' ') lhs = lhs//lower(a(k:k))
    end do
  end function assignment_lhs

  !> The position of the first `sep` in s at or after `from`; len(s)+1 when
  !> none: the end of an item of a list separated by sep.
  pure integer function item_end(s, from, sep) result(q)
    character(*), intent(in) :: s, sep
    integer, intent(in) :: from
    q = index(s(from:), sep)
    if (q == 0) then
      q = len(s) + 1
    else
      q = from + q - 1
    end if
  end function item_end

  !> An assignment without blanks and commas at its ends.
  function strip_commas(s) result(r)
    character(*), intent(in) :: s
    character(:), allocatable :: r
    integer :: e, b
    e = len(s)
    do while (e > 0)
      if (s(e:e) /= ',' .and. s(e:e) /= ' ') exit
      e = e - 1
    end do
    b = 1
    do while (b <= e)
      if (s(b:b) /= ',' .and. s(b:b) /= ' ') exit
      b = b + 1
    end do
    r = s(b:e)
  end function strip_commas

  pure function lower(s) result(r)
    character(*), intent(in) :: s
    character(len(s)) :: r
    integer :: i
    r = s
    do i = 1, len(s)
      if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') r(i:i) = achar(iachar(s(i:i)) + 32)
    end do
  end function lower

end module input_text
