! SPDX-License-Identifier: BSD-2-Clause
!> Reads, completes and checks the run configuration (namelist input, in the
!> manner of CaNS). Rank 0 reads the file; every rank parses the same text, so
!> every rank reaches the same result and the same error: a bad input stops
!> all ranks together and never hangs. Order: &scene (for the scene name),
!> that scene's defaults, all groups over them, derived values, checks.
!> Errors come back in ierr/errmsg; this module prints nothing and never stops.
!> The rooms below it: input_keys (the key table), input_text (-nuno_set
!> lexer, value types, number text), input_scan (the file's text made ready
!> for the reader), input_checks (derived values, checks), input_resources
!> (steps, index space, memory), input_usage (--help, --list-keys).
module input
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, keyframe_max, unset_real, &
                    BEND_NONE, BEND_PAPER, BEND_ENERGY, SCENE_WAVE_POINT, SCENE_HANG, SCENE_LIFT_RELEASE, obstacle_max
  use input_text, only: assignment_t, lex_overrides, value_error, next_assignment, lower, &
                        strip_commas, overrides_record, key_default, namelist_value, assignment_lhs
  use strings, only: real_short, itoa
  use input_keys, only: keys, n_keys, n_groups, group_names, KEY_REAL, G_LATTICE, G_MATERIAL, G_SCENE, G_TIME, G_OUTPUT, &
                        G_IDENTIFY, G_CONTROL, G_CONTACT
  use input_scan, only: parsed_text, scan_text, group_index
  use input_namelist, only: namelist_read, namelist_write
  use input_checks, only: derive_codes, resolve_unset, validate, check_choice, &
                          choices, check_lattice
  use input_resources, only: input_check_run
  implicit none
  private
  public :: input_read, input_summary, input_parse, input_check_run, input_namelist_dump

  integer, parameter :: msg_len = 1024


contains

  ! ==========================================================================
  ! Reading and broadcasting
  ! ==========================================================================

  !> Read the namelist file `path` on rank 0, broadcast it, parse it on
  !> every rank with the n_set -nuno_set options of `overrides` over it.
  subroutine input_read(path, comm, overrides, n_set, cfg, ierr, errmsg)
    character(*), intent(in) :: path          !< input file name
    integer, intent(in) :: comm               !< MPI communicator of the run
    character(*), intent(in) :: overrides     !< -nuno_set: key=value,... over the file (options joined by line feeds)
    integer, intent(in) :: n_set              !< how many -nuno_set options overrides holds; 0: none, overrides unread
    type(nuno_config), intent(out) :: cfg     !< the complete, checked configuration
    integer, intent(out) :: ierr              !< 0: fine; else errmsg says why (same on all ranks)
    character(*), intent(out) :: errmsg       !< one-line message; blank when ierr = 0
    character(:), allocatable :: text
    character(msg_len) :: iomsg
    integer :: rank, mpierr, u, ios, nbytes, hdr(2)

    ierr = 0
    errmsg = ''
    call MPI_Comm_rank(comm, rank, mpierr)
    hdr = 0
    if (rank == 0) then
      ! Whole file as one string; a failure leaves its reason in text instead.
      iomsg = ''
      open(newunit=u, file=path, access='stream', form='unformatted', action='read', &
           status='old', iostat=ios, iomsg=iomsg)
      if (ios == 0) then
        inquire(unit=u, size=nbytes)
        if (nbytes < 0) then
          ios = 1
          iomsg = 'size unknown'
        else
          allocate(character(nbytes) :: text)
          if (nbytes > 0) read(u, iostat=ios, iomsg=iomsg) text
        end if
        close(u)
      end if
      if (ios /= 0) then
        text = trim(iomsg)
        hdr(1) = 1
      end if
      hdr(2) = len(text)
    end if
    call MPI_Bcast(hdr, 2, MPI_INTEGER, 0, comm, mpierr)
    if (rank /= 0) allocate(character(hdr(2)) :: text)
    if (hdr(2) > 0) call MPI_Bcast(text, hdr(2), MPI_CHARACTER, 0, comm, mpierr)
    if (hdr(1) /= 0) then
      ierr = 1
      errmsg = "input: cannot open input file '"//trim(path)//"' ("//text//")"
      return
    end if
    call parse_text(text, overrides, n_set, cfg, ierr, errmsg)
  end subroutine input_read

  !> Parse namelist text (no MPI, no -nuno_set): a configuration from a
  !> string, for tests and tools.
  subroutine input_parse(text, cfg, ierr, errmsg)
    character(*), intent(in) :: text           !< the whole namelist file
    type(nuno_config), intent(out) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    call parse_text(text, '', 0, cfg, ierr, errmsg)
  end subroutine input_parse

  !> Parse namelist text (no MPI): scene, scene defaults, groups, the n_set
  !> -nuno_set options of `overrides`, derived values, checks.
  subroutine parse_text(text, overrides, n_set, cfg, ierr, errmsg)
    character(*), intent(in) :: text           !< the whole namelist file
    character(*), intent(in) :: overrides      !< -nuno_set: key=value,... read after the file
    integer, intent(in) :: n_set               !< how many -nuno_set options overrides holds; 0: none
    type(nuno_config), intent(out) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    type(parsed_text) :: pt
    type(nuno_config) :: first
    character(msg_len) :: msg
    integer :: code

    ierr = 0
    errmsg = ''
    msg = ''
    if (verify(text, ' '//achar(9)//achar(10)//achar(13)) == 0) then
      ierr = 1
      msg = 'input: the input file is empty (nothing but blanks): it must hold at least one namelist group'
      goto 900
    end if
    call scan_text(text, pt, ierr, msg)
    if (ierr /= 0) goto 900
    if (all(pt%count == 0)) then
      ierr = 1
      msg = 'input: no namelist group in the input (only comments): it must hold at least one of '// &
            '&scene, &lattice, &material, &time, &output'
      goto 900
    end if

    ! 1. The scene name alone, read over the plain defaults.
    call read_group(G_SCENE, pt, first, ierr, msg)
    if (ierr /= 0) goto 900
    if (n_set > 0) then
      call apply_overrides(overrides, first, .true., ierr, msg)
      if (ierr /= 0) goto 900
    end if
    first%scene%name = lower(adjustl(first%scene%name))
    call check_choice('scene', 'scene', first%scene%name, choices('scene'), code, ierr, msg)
    if (ierr /= 0) goto 900

    ! 2. That scene's defaults; keys whose default depends on other keys start unset.
    call table_defaults(trim(first%scene%name), code, cfg, ierr, msg)
    if (ierr /= 0) goto 900
    cfg%material%k_b = unset_real
    cfg%material%eta_b = unset_real
    cfg%lattice%mass_distribution = ''

    ! 3. Every group over them (&scene again, so its other keys see the scene's defaults).
    call read_group(G_SCENE, pt, cfg, ierr, msg);    if (ierr /= 0) goto 900
    call read_group(G_LATTICE, pt, cfg, ierr, msg);  if (ierr /= 0) goto 900
    call read_group(G_MATERIAL, pt, cfg, ierr, msg); if (ierr /= 0) goto 900
    call read_group(G_TIME, pt, cfg, ierr, msg);     if (ierr /= 0) goto 900
    call read_group(G_OUTPUT, pt, cfg, ierr, msg);   if (ierr /= 0) goto 900
    call read_group(G_IDENTIFY, pt, cfg, ierr, msg); if (ierr /= 0) goto 900
    call read_group(G_CONTROL, pt, cfg, ierr, msg);  if (ierr /= 0) goto 900
    call read_group(G_CONTACT, pt, cfg, ierr, msg);  if (ierr /= 0) goto 900
    cfg%identify%active = pt%count(G_IDENTIFY) > 0
    cfg%control%active = pt%count(G_CONTROL) > 0
    cfg%namelist_text = text
    if (n_set > 0) then
      ! Command-line keys win over the file's; they are recorded with it.
      call apply_overrides(overrides, cfg, .false., ierr, msg)
      if (ierr /= 0) goto 900
      cfg%namelist_text = text//new_line('a')//'! '//overrides_record(trim(overrides))
    end if
    cfg%scene%name = lower(adjustl(cfg%scene%name))
    cfg%scene%scene_code = code

    ! 4. Choices to codes, lattice spacing, keys left unset, then the checks.
    call derive_codes(cfg, ierr, msg);        if (ierr /= 0) goto 900
    call check_finite_keys(cfg, ierr, msg);   if (ierr /= 0) goto 900
    call check_lattice(cfg, ierr, msg);       if (ierr /= 0) goto 900
    cfg%lattice%ax = cfg%lattice%lx/real(cfg%lattice%nx - 1, rp)
    cfg%lattice%ay = cfg%lattice%ly/real(cfg%lattice%ny - 1, rp)
    call resolve_unset(cfg, ierr, msg);       if (ierr /= 0) goto 900
    cfg%scene%has_gravity = any(cfg%scene%gravity /= 0.0_rp)
    cfg%material%has_damping = cfg%material%eta_s > 0.0_rp .or. cfg%material%eta_d > 0.0_rp
    call validate(cfg, ierr, msg)

900 if (ierr /= 0) errmsg = trim(msg)
  end subroutine parse_text

  ! ==========================================================================
  ! Namelist groups
  ! ==========================================================================

  !> Read group g over cfg when it is present; on error, name the assignment
  !> at fault by reading the group's assignments one at a time.
  subroutine read_group(g, pt, cfg, ierr, msg)
    integer, intent(in) :: g
    type(parsed_text), intent(in) :: pt
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(msg_len) :: iomsg, iomsg1
    type(nuno_config) :: scratch
    integer :: ios, ios1, p, q, nb, e
    character(:), allocatable :: body, a, why

    ierr = 0
    msg = ''
    if (pt%count(g) == 0) return
    body = trim(pt%body(g))
    nb = len(body)
    iomsg = ''
    call namelist_read(g, pt%lines, cfg, ios, iomsg)
    if (ios == 0) then
      call check_values_given(g, body, ierr, msg)
      if (ierr == 0) call check_repeated_keys(g, body, ierr, msg)
      return
    end if
    ierr = 1
    msg = 'input: &'//trim(group_names(g))//': '//trim(iomsg)
    if (g == G_SCENE) call unrename_scene(msg)
    ! Which assignment? Split the body before each "name =" and try each alone.
    p = next_assignment(body, 1)
    do while (p <= nb)
      q = next_assignment(body, p + 1)
      block
        character(q - p + 32) :: one(1)
        one(1) = '&'//trim(group_names(g))//' '//body(p:q - 1)//' /'
        scratch = cfg
        iomsg1 = ''
        call namelist_read(g, one, scratch, ios1, iomsg1)
      end block
      if (ios1 /= 0) then
        ! The key and the type it expects, where the value is not of it
        ! (the reader's own message, e.g. "Cannot match namelist object
        ! name .5" for nx = 33.5, names neither).
        a = strip_commas(body(p:q - 1))
        e = index(a, '=')
        why = obstacle_index_error(group_names(g), assignment_key(a))
        if (len(why) == 0) why = value_error(assignment_key(a), a(e + 1:))
        if (len(why) > 0) then
          msg = 'input: &'//trim(group_names(g))//': '//trim(adjustl(a(1:e - 1)))//' = '// &
                strip_commas(a(e + 1:))//': '//why
        else
          msg = 'input: &'//trim(group_names(g))//': '//trim(iomsg1)//' (in: '//a//')'
        end if
        if (g == G_SCENE) call unrename_scene(msg)
        return
      end if
      p = q
    end do
  end subroutine read_group

  !> An &contact key of an obstacle (obstacle_*) whose obstacle index, its
  !> last subscript, is beyond obstacle_max: the reader's own message
  !> ("Index 1 out of range") names neither the obstacle nor the limit.
  !> '' for any other key.
  function obstacle_index_error(group, key) result(why)
    character(*), intent(in) :: group, key
    character(:), allocatable :: why
    integer :: b, c, e, k, n, ios
    character(:), allocatable :: sub
    why = ''
    if (trim(group) /= 'contact' .or. len(key) < 10) return
    if (key(1:9) /= 'obstacle_') return
    b = index(key, '(')
    e = index(key, ')', back=.true.)
    if (b == 0 .or. e <= b) return
    sub = key(b + 1:e - 1)
    c = index(sub, ',', back=.true.)
    sub = sub(c + 1:)
    ! an index or a range lo:hi: its largest number
    n = 0
    do while (len(sub) > 0)
      c = index(sub, ':')
      if (c == 0) c = len(sub) + 1
      read(sub(1:c - 1), *, iostat=ios) k
      if (ios == 0) n = max(n, k)
      if (c > len(sub)) exit
      sub = sub(c + 1:)
    end do
    if (n <= obstacle_max) return
    why = 'obstacle '//itoa(n)//' is beyond the last one nuno takes, obstacle '//itoa(obstacle_max)// &
          ' (n_obstacles <= '//itoa(obstacle_max)//')'
  end function obstacle_index_error
  !> An assignment without a value (`nx = ,`, `nx =` before the next key or
  !> the group's end) or with an empty item in its list (`gravity = 0, , -9.81`)
  !> is refused by name: the namelist reader takes an empty value as "keep
  !> the default" and would run with it silently.
  subroutine check_values_given(g, body, ierr, msg)
    integer, intent(in) :: g
    character(*), intent(in) :: body
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: p, q, e
    character(:), allocatable :: a, value

    ierr = 0
    msg = ''
    p = next_assignment(body, 1)
    do while (p <= len(body))
      q = next_assignment(body, p + 1)
      a = blanks_to_spaces(body(p:q - 1))
      e = index(a, '=')
      value = strip_commas(a(e + 1:))
      if (len(value) == 0) then
        ierr = 1
        msg = 'input: &'//trim(group_names(g))//': '//assignment_key(a)//' has no value (in: '// &
              trim(adjustl(a))//'): give a value or leave the key out (an empty value would keep '// &
              'the default silently)'
      else if (has_empty_item(value)) then
        ierr = 1
        msg = 'input: &'//trim(group_names(g))//': '//assignment_key(a)//' = '//value// &
              ': an empty item in the list (it would keep that element''s default silently): give every value'
      end if
      if (ierr /= 0) then
        if (g == G_SCENE) call unrename_scene(msg)
        return
      end if
      p = q
    end do
  contains
    !> Tabs and line ends as blanks (a group's body keeps its lines).
    function blanks_to_spaces(s) result(r)
      character(*), intent(in) :: s
      character(len(s)) :: r
      integer :: i
      r = s
      do i = 1, len(r)
        if (r(i:i) == achar(9) .or. r(i:i) == achar(10) .or. r(i:i) == achar(13)) r(i:i) = ' '
      end do
    end function blanks_to_spaces
    !> Two commas with only blanks between them, outside quotes.
    logical function has_empty_item(v)
      character(*), intent(in) :: v
      character(1) :: quote
      integer :: i
      logical :: after_comma
      has_empty_item = .false.
      quote = ' '
      after_comma = .false.
      do i = 1, len(v)
        if (quote /= ' ') then
          if (v(i:i) == quote) quote = ' '
          cycle
        end if
        select case (v(i:i))
        case ("'", '"')
          quote = v(i:i)
          after_comma = .false.
        case (',')
          if (after_comma) then
            has_empty_item = .true.
            return
          end if
          after_comma = .true.
        case (' ')
        case default
          after_comma = .false.
        end select
      end do
    end function has_empty_item
  end subroutine check_values_given

  !> A key given twice in group g's body (the namelist reader would keep the
  !> last value silently) is refused by name; an array's element and the
  !> whole array count as the same key.
  subroutine check_repeated_keys(g, body, ierr, msg)
    integer, intent(in) :: g
    character(*), intent(in) :: body
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(64) :: keys(4*keyframe_max + 64)
    integer :: starts(size(keys)), ends(size(keys))
    integer :: n, p, q, k, b1, b2
    character(:), allocatable :: key

    ierr = 0
    msg = ''
    n = 0
    p = next_assignment(body, 1)
    do while (p <= len(body) .and. n < size(keys))
      q = next_assignment(body, p + 1)
      key = assignment_key(body(p:q - 1))
      b1 = index(key//'(', '(')
      do k = 1, n
        b2 = index(trim(keys(k))//'(', '(')
        if (key(1:b1 - 1) /= keys(k)(1:b2 - 1)) cycle
        if (key == keys(k) .or. b1 > len(key) .or. b2 > len_trim(keys(k))) then
          ierr = 1
          msg = 'input: &'//trim(group_names(g))//': '//key//' is given twice ('// &
                strip_commas(body(starts(k):ends(k)))//' and '//strip_commas(body(p:q - 1))//'): give each key once'
          if (g == G_SCENE) call unrename_scene(msg)
          return
        end if
      end do
      n = n + 1
      keys(n) = key
      starts(n) = p
      ends(n) = q - 1
      p = q
    end do
  end subroutine check_repeated_keys

  !> The key of an assignment "key = value" of a group's body: lower case,
  !> without blanks, the renamed `scene_name` back to `scene`.
  function assignment_key(a) result(key)
    character(*), intent(in) :: a
    character(:), allocatable :: key
    key = assignment_lhs(a)
    if (len(key) >= 10) then
      if (key(1:10) == 'scene_name') key = 'scene'//key(11:)
    end if
  end function assignment_key

  !> -nuno_set: assignments key=value separated by commas or blanks
  !> (namelist syntax: strings quoted, arrays listed, elements by subscript),
  !> each key by its name alone (names are unique across groups) or as
  !> group%key, read over cfg as if written in its group; several -nuno_set
  !> options (joined by line feeds) in order. The text is checked as a whole
  !> first (module input_text: an empty value, a key given twice, a value
  !> not of its key's type are refused by name), so no key is dropped
  !> silently. scene_only: apply the key `scene` only (the scene picks the
  !> defaults before the groups are read).
  subroutine apply_overrides(ov, cfg, scene_only, ierr, msg)
    character(*), intent(in) :: ov
    type(nuno_config), intent(inout) :: cfg
    logical, intent(in) :: scene_only
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(msg_len) :: iomsg
    type(assignment_t), allocatable :: items(:)
    character(:), allocatable :: key, lexmsg
    integer :: k, g, ios

    msg = ''
    call lex_overrides(ov, items, ierr, lexmsg)
    if (ierr /= 0) then
      msg = lexmsg
      return
    end if
    do k = 1, size(items)
      if (scene_only .and. items(k)%base /= 'scene') cycle
      g = group_index(items(k)%group)
      key = items(k)%key
      if (items(k)%base == 'scene') key = 'scene_name'//key(6:)
      block
        character(len(key) + len(items(k)%value) + 32) :: line(1)
        line(1) = '&'//trim(group_names(g))//' '//key//' = '//items(k)%value//' /'
        iomsg = ''
        call namelist_read(g, line, cfg, ios, iomsg)
      end block
      if (ios /= 0) then
        ierr = 1
        msg = 'input: -nuno_set: &'//trim(group_names(g))//': '//trim(iomsg)//' (in: '//items(k)%text//')'
        if (len(obstacle_index_error(group_names(g), items(k)%key)) > 0) &
          msg = 'input: -nuno_set: &'//trim(group_names(g))//': '//items(k)%text//': '// &
                obstacle_index_error(group_names(g), items(k)%key)
        call unrename_scene(msg)
        return
      end if
    end do
  end subroutine apply_overrides

  !> Undo the rename of the key `scene` in a message.
  subroutine unrename_scene(msg)
    character(*), intent(inout) :: msg
    integer :: p
    p = index(msg, 'scene_name')
    do while (p > 0)
      msg = msg(1:p + 4)//msg(p + 10:)
      p = index(msg, 'scene_name')
    end do
  end subroutine unrename_scene

  !> The defaults of scene `scene` (code: its position in the key table's
  !> list of scenes): the configuration's initial values (module config),
  !> then every default of the key table (module input_keys) that is a value
  !> in that scene, read through the namelist reader itself, so that the
  !> table is the one place of the defaults. Report scenes: mm, g, s; E =
  !> eta = 1 per link; paper bending k_b = 1 (docs/model.md section 7).
  subroutine table_defaults(scene, code, cfg, ierr, msg)
    character(*), intent(in) :: scene
    integer, intent(in) :: code
    type(nuno_config), intent(out) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: body, v
    character(msg_len) :: iomsg
    integer :: g, k, ios
    ierr = 0
    msg = ''
    do g = 1, n_groups
      body = ''
      do k = 1, n_keys
        if (trim(keys(k)%group) /= trim(group_names(g)) .or. trim(keys(k)%name) == 'scene') cycle
        v = key_default(k, scene)
        if (len(v) > 0) body = body//' '//trim(keys(k)%name)//' = '//v//','
      end do
      if (len(body) == 0) cycle
      block
        character(len(body) + 32) :: line(1)
        line(1) = '&'//trim(group_names(g))//body//' /'
        iomsg = ''
        call namelist_read(g, line, cfg, ios, iomsg)
      end block
      if (ios /= 0) then
        ierr = 1
        msg = 'input: the key table''s defaults of &'//trim(group_names(g))//' for scene '//scene// &
              ' cannot be read: '//trim(iomsg)
        return
      end if
    end do
    cfg%scene%name = scene
    cfg%scene%scene_code = code
  end subroutine table_defaults

  !> Every real key of the key table finite: NaN or Inf would pass some
  !> range checks (a NaN compares false both ways) and run, writing NaN into
  !> the output. The values are read back from the reader's own namelist
  !> WRITE of each group, so that no key is left out; an array is named with
  !> the subscript of its first bad element.
  subroutine check_finite_keys(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: dump, v
    real(rp), allocatable :: values(:)
    character(16) :: sub
    integer :: g, k, i, ios
    ierr = 0
    msg = ''
    do g = 1, n_groups
      call input_namelist_dump(cfg, trim(group_names(g)), dump, ios)
      do k = 1, n_keys
        if (trim(keys(k)%group) /= trim(group_names(g)) .or. keys(k)%kind /= KEY_REAL) cycle
        v = namelist_value(dump, trim(keys(k)%name))
        if (allocated(values)) deallocate(values)
        allocate(values(keys(k)%size))
        if (ios == 0) read(v, *, iostat=ios) values
        if (ios /= 0 .or. len(v) == 0) then
          ierr = 1
          msg = 'input: internal error: the value of &'//trim(group_names(g))//' '//trim(keys(k)%name)// &
                ' cannot be read back'
          return
        end if
        do i = 1, keys(k)%size
          if (abs(values(i)) <= huge(values(i))) cycle
          ierr = 1
          sub = ''
          if (keys(k)%size > 1) write(sub, '(a,i0,a)') '(', i, ')'
          msg = 'input: &'//trim(group_names(g))//': '//trim(keys(k)%name)//trim(sub)//' = '// &
                real_short(values(i))//' must be a finite number'
          return
        end do
      end do
    end do
  end subroutine check_finite_keys

  !> The namelist text of group `group` ('lattice', ...) with cfg's values,
  !> as the reader's own namelist WRITE gives it (gfortran: upper-case
  !> names, records joined by line feeds; the key `scene` as SCENE_NAME).
  !> It names exactly the keys the reader reads, with their sizes and types:
  !> tests/mpi/test_input_keys.F90 checks the key table against it.
  subroutine input_namelist_dump(cfg, group, text, ios)
    type(nuno_config), intent(in) :: cfg
    character(*), intent(in) :: group
    character(:), allocatable, intent(out) :: text
    integer, intent(out) :: ios
    text = ''
    ios = 1
    if (group_index(group) == 0) return
    call namelist_write(group_index(group), cfg, text, ios)
  end subroutine input_namelist_dump

  ! ==========================================================================
  ! Help and summary
  ! ==========================================================================

  !> Write a few lines that describe the run (call on one rank).
  subroutine input_summary(cfg, unit, ts_dt, ts_dt_set, ts_max_time, ts_max_time_set)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: unit
    real(rp), intent(in) :: ts_dt, ts_max_time         !< -ts_dt, -ts_max_time [time]: they win where given
    logical, intent(in) :: ts_dt_set, ts_max_time_set  !< whether -ts_dt, -ts_max_time are given
    character(256) :: terms, cons
    character(len=:), allocatable :: tline
    write(unit, '(a)') 'scene     : '//trim(cfg%scene%name)
    write(unit, '(a,i0,a,i0,a)') 'lattice   : ', cfg%lattice%nx, ' x ', cfg%lattice%ny, ' nodes, '// &
      real_short(cfg%lattice%lx)//' x '//real_short(cfg%lattice%ly)//' (spacing '//real_short(cfg%lattice%ax)//' x '// &
      real_short(cfg%lattice%ay)//'), mass '//real_short(cfg%lattice%total_mass)//' ('//trim(cfg%lattice%mass_distribution)// &
      '), '//trim(cfg%lattice%lattice_scaling)//' constants'
    write(unit, '(a)') 'springs   : '//trim(cfg%material%spring_model)//': E_s = '//real_short(cfg%material%e_s)// &
      ', eta_s = '//real_short(cfg%material%eta_s)//', E_d = '//real_short(cfg%material%e_d)//', eta_d = '//real_short(cfg%material%eta_d)
    select case (cfg%material%bending_code)
    case (BEND_NONE)
      write(unit, '(a)') 'bending   : none'
    case (BEND_PAPER)
      write(unit, '(a)') 'bending   : paper (report eqs. 2-3): k_b = '//real_short(cfg%material%k_b)//' per radian'
    case (BEND_ENERGY)
      write(unit, '(a)') 'bending   : energy: k_b = '//real_short(cfg%material%k_b)//', eta_b = '//real_short(cfg%material%eta_b)
    end select
    terms = ''
    if (cfg%material%bending_code /= BEND_NONE) terms = trim(terms)//', bending'
    if (cfg%material%has_damping .or. (cfg%material%bending_code == BEND_ENERGY .and. cfg%material%eta_b > 0.0_rp)) &
      terms = trim(terms)//', damping'
    if (cfg%scene%has_gravity) terms = trim(terms)//', gravity ('//real_short(cfg%scene%gravity(1))//', '// &
      real_short(cfg%scene%gravity(2))//', '//real_short(cfg%scene%gravity(3))//')'
    if (any(cfg%scene%initial_omega /= 0.0_rp)) terms = trim(terms)//', initial spin'
    write(unit, '(a)') 'terms     : springs'//trim(terms)
    select case (cfg%scene%scene_code)
    case (SCENE_LIFT_RELEASE); cons = 'edge i = 0 pinned'
    case (SCENE_WAVE_POINT)
      if (trim(cfg%scene%wave_nodes) == 'edge') then
        cons = 'edge i = 0 prescribed through keyframes'
      else
        cons = 'corner (0,0) prescribed through keyframes'
      end if
    case (SCENE_HANG);         cons = 'corners (0,ny-1) and (nx-1,ny-1) pinned'
    case default;              cons = 'none'
    end select
    if (cfg%scene%release_time < huge(1.0_rp) .and. trim(cons) /= 'none') &
      cons = trim(cons)//', released at t = '//real_short(cfg%scene%release_time)
    write(unit, '(a)') 'constraint: '//trim(cons)
    ! The values the run uses: an option over the namelist says so.
    if (ts_max_time_set) then
      tline = 'time      : t_end = '//real_short(ts_max_time)//' (-ts_max_time; namelist '//real_short(cfg%time%t_end)//')'
    else
      tline = 'time      : t_end = '//real_short(cfg%time%t_end)
    end if
    if (ts_dt_set) then
      tline = tline//', dt = '//real_short(ts_dt)//' (-ts_dt; namelist '//real_short(cfg%time%dt)//')'
    else
      tline = tline//', dt = '//real_short(cfg%time%dt)
    end if
    write(unit, '(a)') tline
    if (cfg%output%write_velocity) then
      write(unit, '(a)') 'output    : '//trim(cfg%output%output_file)//' every '//real_short(cfg%output%output_interval)// &
        ' (with velocity)'
    else
      write(unit, '(a)') 'output    : '//trim(cfg%output%output_file)//' every '//real_short(cfg%output%output_interval)
    end if
  end subroutine input_summary

end module input
