! SPDX-License-Identifier: BSD-2-Clause
!> The key table (module input_keys) against the namelist reader (module
!> input), so that the two cannot drift apart:
!> - each group the reader reads names exactly the table's keys of that
!>   group, with the table's type and size (from the reader's own namelist
!>   WRITE of the group, input_namelist_dump);
!> - each default of the table that is a value, in every scene, is the
!>   reader's: setting the key to it changes nothing;
!> - each simple range (> X, >= X, and lists of bounds such as
!>   ">= 0, <= 1e30") and choice list of the table is what the checks
!>   refuse and accept; every real key is refused as NaN.
!> Run on 1 and 3 ranks (the parsing itself uses no MPI).
program test_input_keys
  use mpi
  use config, only: nuno_config
  use input, only: input_parse, input_namelist_dump
  use input_keys, only: keys, n_keys, key_index, group_names, n_groups, KEY_INTEGER, KEY_REAL, KEY_LOGICAL, &
                        KEY_STRING
  use input_text, only: lower, key_default
  use check, only: check_true, check_report
  implicit none
  integer :: mpierr, k, g, s, n_checked
  character(:), allocatable :: scenes(:), v, text0, text1
  character(1024) :: msg
  integer :: ierr
  type(nuno_config) :: cfg0, cfg1

  call MPI_Init(mpierr)

  ! ---- 1. the reader's groups hold exactly the table's keys ------------------
  call input_parse("&scene /", cfg0, ierr, msg)
  call check_true(ierr == 0, 'plain defaults parse: '//trim(msg))
  do g = 1, n_groups
    call check_group(trim(group_names(g)), cfg0)
  end do

  ! ---- 2. defaults: the table's value in each scene is the reader's ---------
  scenes = split(trim(keys(key_index('scene'))%allowed))
  call check_true(size(scenes) == 5, 'five scenes in the table')
  call input_parse("&time /", cfg0, ierr, msg)
  call input_parse("&scene scene = "//trim(keys(key_index('scene'))%default)//" /", cfg1, ierr, msg)
  call check_true(ierr == 0 .and. dump_all(cfg0) == dump_all(cfg1), 'default scene is the table''s')
  n_checked = 0
  do s = 1, size(scenes)
    do k = 1, n_keys
      if (trim(keys(k)%name) == 'scene') cycle
      if (trim(keys(k)%group) == 'control' .and. trim(scenes(s)) /= 'wave_point') cycle
      v = key_default(k, trim(scenes(s)))
      if (len(v) == 0) cycle
      call input_parse(input_with(k, trim(scenes(s)), ''), cfg0, ierr, msg)
      call check_true(ierr == 0, 'base input parses: '//trim(msg))
      text0 = dump_all(cfg0)
      call input_parse(input_with(k, trim(scenes(s)), trim(keys(k)%name)//' = '//v), cfg1, ierr, msg)
      call check_true(ierr == 0, trim(keys(k)%name)//' = '//v//' parses: '//trim(msg))
      text1 = dump_all(cfg1)
      call check_true(text0 == text1, 'scene '//trim(scenes(s))//': the table''s default of '// &
                      trim(keys(k)%name)//' ('//v//') is the reader''s')
      n_checked = n_checked + 1
    end do
  end do
  ! 5 scenes x ~33 keys whose default is a value: a parse of the default
  ! column that skipped them all would pass silently.
  call check_true(n_checked > 150, 'defaults checked for most keys')

  ! ---- 3. ranges and choices --------------------------------------------------
  do k = 1, n_keys
    call check_range(k)
  end do

  ! ---- 4. every real key of the table is refused as NaN, by name ------------
  do k = 1, n_keys
    if (keys(k)%kind /= KEY_REAL) cycle
    v = trim(keys(k)%name)
    if (trim(keys(k)%group) == 'control') then
      call input_parse(input_with(k, 'wave_point', v//' = NaN'), cfg1, ierr, msg)
    else
      call input_parse(input_with(k, 'lift_release', v//' = NaN'), cfg1, ierr, msg)
    end if
    call check_true(ierr /= 0 .and. index(msg, v) > 0, v//' = NaN is refused by name: '//trim(msg))
  end do

  call check_report()
  call MPI_Finalize(mpierr)

contains

  !> Group `group`'s names, types and sizes in the reader's namelist WRITE
  !> against the table.
  subroutine check_group(group, cfg)
    character(*), intent(in) :: group
    type(nuno_config), intent(in) :: cfg
    character(:), allocatable :: text, line
    character(32) :: names(64)
    character(4096) :: vals(64)
    integer :: ios, p, q, e, n, i, kk, kt, kind, count
    call input_namelist_dump(cfg, group, text, ios)
    call check_true(ios == 0, '&'//group//' written')
    ! Records "&GROUP", " NAME=value ,", continuation " value ,", " /".
    n = 0
    p = 1
    do while (p <= len(text))
      q = index(text(p:), new_line('a')) + p - 1
      line = trim(adjustl(text(p:q - 1)))
      p = q + 1
      if (len(line) == 0) cycle
      e = index(line, '=')
      if (e > 1) then
        if (verify(line(1:e - 1), 'ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_') == 0) then
          n = n + 1
          names(n) = lower(line(1:e - 1))
          if (names(n) == 'scene_name') names(n) = 'scene'
          vals(n) = line(e + 1:)
          cycle
        end if
      end if
      if (line(1:1) == '&' .or. line(1:1) == '/') cycle
      if (n > 0) vals(n) = trim(vals(n))//' '//line
    end do
    do i = 1, n
      kt = key_index(trim(names(i)))
      call check_true(kt > 0, '&'//group//' '//trim(names(i))//' is in the table')
      if (kt == 0) cycle
      call check_true(trim(keys(kt)%group) == group, trim(names(i))//' is in the table''s group &'//group)
      call value_shape(trim(vals(i)), kind, count)
      call check_true(keys(kt)%kind == kind, trim(names(i))//': the table''s type is the reader''s')
      call check_true(keys(kt)%size == count, trim(names(i))//': the table''s size is the reader''s')
    end do
    do kk = 1, n_keys
      if (trim(keys(kk)%group) /= group) cycle
      call check_true(any(names(1:n) == keys(kk)%name), &
                      'the table''s key '//trim(keys(kk)%name)//' is read in &'//group)
    end do
  end subroutine check_group

  !> Type (KEY_*) and number of values of a namelist WRITE's value text.
  subroutine value_shape(vv, kind, count)
    character(*), intent(in) :: vv
    integer, intent(out) :: kind, count
    character(:), allocatable :: items(:), it
    integer :: i, star, r
    items = split(vv)
    count = 0
    kind = 0
    do i = 1, size(items)
      it = trim(adjustl(items(i)))
      if (len(it) == 0) cycle
      r = 1
      star = index(it, '*')
      if (star > 1 .and. verify(it(1:1), '''"') /= 0) then
        read(it(1:star - 1), *) r
        it = it(star + 1:)
      end if
      count = count + r
      if (kind /= 0) cycle
      if (verify(it(1:1), '''"') == 0) then
        kind = KEY_STRING
      else if (it == 'T' .or. it == 'F') then
        kind = KEY_LOGICAL
      else if (scan(it, '.EN') > 0) then
        kind = KEY_REAL
      else
        kind = KEY_INTEGER
      end if
    end do
  end subroutine value_shape

  !> An input of scene `scene` with the assignment `a` in key k's group,
  !> and what key k's group needs to be valid (&identify: an observed file
  !> and a parameter; &control: a target file).
  function input_with(k, scene, a) result(t)
    integer, intent(in) :: k
    character(*), intent(in) :: scene, a
    character(:), allocatable :: t
    character(:), allocatable :: grp
    grp = trim(keys(k)%group)
    if (trim(keys(k)%name) == 'scene') then
      t = '&scene '//a//' /'
      return
    end if
    t = "&scene scene = '"//scene//"'"
    if (grp == 'scene') t = t//', '//a
    t = t//' /'//new_line('a')
    select case (grp)
    case ('scene')
    case ('identify')
      t = t//"&identify observed_file = 'o.h5', fit = 'e_s'"
      if (trim(keys(k)%name) /= 'fit' .and. trim(keys(k)%name) /= 'observed_file' .and. len(a) > 0) t = t//', '//a
      t = t//' /'
    case ('control')
      t = t//"&control target_file = 't.h5'"
      if (trim(keys(k)%name) /= 'target_file' .and. len(a) > 0) t = t//', '//a
      t = t//' /'
    case default
      t = t//'&'//grp//' '//a//' /'
    end select
  end function input_with

  !> Every group's namelist WRITE of cfg, one text.
  function dump_all(cfg) result(t)
    type(nuno_config), intent(in) :: cfg
    character(:), allocatable :: t, one
    integer :: gg, ios
    t = ''
    do gg = 1, n_groups
      call input_namelist_dump(cfg, trim(group_names(gg)), one, ios)
      t = t//one
    end do
  end function dump_all

  !> A range of bounds of a scalar number ("> X", ">= X", "<= Y", "< Y",
  !> separated by ', '): a value beyond each is refused naming the key, the
  !> bound of ">=" and "<=" accepted. A choice list:
  !> each listed value accepted as a choice, another refused with the list.
  subroutine check_range(k)
    integer, intent(in) :: k
    character(:), allocatable :: r, nm, bad, good, words(:), sc, part, op
    real(8) :: x
    integer :: ios, i, p, q
    r = trim(keys(k)%allowed)
    nm = trim(keys(k)%name)
    bad = ''
    good = ''
    sc = 'lift_release'
    if (trim(keys(k)%group) == 'control') sc = 'wave_point'
    if (keys(k)%size /= 1) return
    if (keys(k)%kind == KEY_INTEGER .or. keys(k)%kind == KEY_REAL) then
      ! Each leading bound of the list (">= A, <= B"; a text after them,
      ! "or 0: no check", ends it): a value beyond it refused by name, the
      ! bound of ">=" and "<=" itself accepted.
      p = 1
      do while (p <= len(r))
        q = index(r(p:)//', ', ', ') + p - 1
        part = r(p:q - 1)
        op = part(1:verify(part, '<>=') - 1)
        read(part(len(op) + 1:), *, iostat=ios) x
        if (len(op) == 0 .or. ios /= 0) exit
        good = ''
        select case (op)
        case ('>=')
          good = adjustl(part(3:))
          bad = num(x - 1.0d0)
        case ('>')
          bad = adjustl(part(2:))
        case ('<=')
          good = adjustl(part(3:))
          bad = num(merge(x * 10.0d0, x + 1.0d0, x > 0.0d0))
        case default
          bad = adjustl(part(2:))
        end select
        if (keys(k)%kind == KEY_REAL .and. verify(bad, '-0123456789') == 0) bad = bad//'.0'
        call input_parse(input_with(k, sc, nm//' = '//bad), cfg1, ierr, msg)
        call check_true(ierr /= 0 .and. index(msg, nm) > 0, nm//' = '//bad//' is refused by name ('// &
                        r//'): '//trim(msg))
        if (len(good) > 0) then
          call input_parse(input_with(k, sc, nm//' = '//good), cfg1, ierr, msg)
          call check_true(ierr == 0, nm//' = '//good//' is accepted ('//r//'): '//trim(msg))
        end if
        p = q + 2
      end do
    else if (keys(k)%kind == KEY_STRING .and. index(r, ', ') > 0 .and. &
             verify(r, 'abcdefghijklmnopqrstuvwxyz_, ') == 0 .and. nm /= 'fit') then
      words = split(r)
      ! A choice list is single words ('letters of xyz, each once' is not).
      do i = 1, size(words)
        if (index(trim(adjustl(words(i))), ' ') > 0) return
      end do
      do i = 1, size(words)
        call input_parse(input_with(k, sc, nm//" = '"//trim(adjustl(words(i)))//"'"), cfg1, ierr, msg)
        call check_true(index(msg, 'is not one of') == 0, nm//" = '"//trim(adjustl(words(i)))// &
                        "' is a choice: "//trim(msg))
      end do
      call input_parse(input_with(k, sc, nm//" = 'nonsense'"), cfg1, ierr, msg)
      call check_true(ierr /= 0 .and. index(msg, nm) > 0 .and. index(msg, 'is not one of '//r) > 0, &
                      nm//" = 'nonsense' is refused with the table's list: "//trim(msg))
    end if
  end subroutine check_range

  function num(x) result(s)
    real(8), intent(in) :: x
    character(:), allocatable :: s
    character(32) :: buf
    write(buf, '(g0)') x
    s = trim(adjustl(buf))
    if (index(s, '.') > 0) then
      do while (s(len(s):len(s)) == '0')
        s = s(1:len(s) - 1)
      end do
      if (s(len(s):len(s)) == '.') s = s(1:len(s) - 1)
    end if
  end function num

  !> Items of a comma-separated list (quotes respected), untrimmed.
  function split(t) result(items)
    character(*), intent(in) :: t
    character(:), allocatable :: items(:)
    integer :: i, n, start, m
    character(1) :: quote
    character(256) :: buf(256)
    n = 0
    start = 1
    quote = ' '
    do i = 1, len(t) + 1
      if (i <= len(t)) then
        if (quote /= ' ') then
          if (t(i:i) == quote) quote = ' '
          cycle
        end if
        if (t(i:i) == "'" .or. t(i:i) == '"') then
          quote = t(i:i)
          cycle
        end if
        if (t(i:i) /= ',') cycle
      end if
      n = n + 1
      buf(n) = adjustl(t(start:i - 1))
      start = i + 1
    end do
    m = maxval(len_trim(buf(1:n)))
    allocate(character(max(1, m)) :: items(n))
    do i = 1, n
      items(i) = buf(i)
    end do
  end function split

end program test_input_keys
