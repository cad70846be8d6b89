!> Reads, completes and checks the run configuration (namelist input, in the
!> manner of CaNS). Rank 0 reads the file; every rank parses the same text, so
!> every rank reaches the same result and the same error: a bad input stops
!> all ranks together and never hangs. Order: &scene (for the scene name),
!> that scene's defaults, all groups over them, derived values, checks.
!> Errors come back in ierr/errmsg; this module prints nothing and never stops.
module input
  use, intrinsic :: iso_fortran_env, only: int64
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, keyframe_max, label_len, path_len, unset_real, &
                    SPRING_AXIAL, SPRING_LINEAR, BEND_NONE, BEND_PAPER, BEND_ENERGY, &
                    SCALING_ELEMENT, SCALING_CONTINUUM, MASS_UNIFORM, MASS_AREA, &
                    SCENE_LIFT_RELEASE, SCENE_BEND_RELEASE, SCENE_WAVE_POINT, SCENE_HANG, SCENE_FLAT, &
                    n_fit_kinds, fit_kind_names
  implicit none
  private
  public :: input_read, input_usage, input_summary, input_parse, input_check_run
  public :: max_steps, max_outputs, bytes_per_node_bending, bytes_per_node_plain

  integer, parameter :: n_groups = 7
  character(8), parameter :: group_names(n_groups) = &
    [character(8) :: 'lattice', 'material', 'scene', 'time', 'output', 'identify', 'control']
  integer, parameter :: G_LATTICE = 1, G_MATERIAL = 2, G_SCENE = 3, G_TIME = 4, G_OUTPUT = 5, G_IDENTIFY = 6, &
                        G_CONTROL = 7
  integer, parameter :: msg_len = 1024

  character(*), parameter :: scene_list = 'lift_release, bend_release, wave_point, hang, flat'

  !> Sane bounds of a run: more steps (t_end/dt) or output steps
  !> (t_end/output_interval) than this need -nuno_allow_long, so that a typo
  !> in dt (1e-12) does not start a job that cannot end.
  real(rp), parameter :: max_steps = 1.0e8_rp, max_outputs = 1.0e5_rp
  !> Memory a lattice node needs on the leanest solver path (reduced
  !> Jacobian, multigrid), measured peak on one rank (docs/performance.md,
  !> "Memory: bytes per node"): 5.7 KB with bending, ~3 KB without. More ranks
  !> and -nuno_jacobian full need more: the check is a lower bound, so it
  !> never refuses a run that could fit.
  real(rp), parameter :: bytes_per_node_bending = 5700.0_rp, bytes_per_node_plain = 3000.0_rp

  !> The input text made ready for the namelist reader: comments and text
  !> outside groups blanked, one record per line; each group's body kept
  !> apart to locate a bad assignment.
  type :: parsed_text
    character(:), allocatable :: lines(:)
    integer :: count(n_groups) = 0
    character(:), allocatable :: body(:)
  end type parsed_text

contains

  ! ==========================================================================
  ! Reading and broadcasting
  ! ==========================================================================

  !> Read the namelist file `path` on rank 0, broadcast it, parse it on every rank.
  subroutine input_read(path, comm, cfg, ierr, errmsg, overrides)
    character(*), intent(in) :: path          !< input file name
    integer, intent(in) :: comm               !< MPI communicator of the run
    type(nuno_config), intent(out) :: cfg     !< the complete, checked configuration
    integer, intent(out) :: ierr              !< 0: fine; else errmsg says why (same on all ranks)
    character(*), intent(out) :: errmsg       !< one-line message; blank when ierr = 0
    character(*), intent(in), optional :: overrides !< -nuno_set: key=value,... over the file
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
    call input_parse(text, cfg, ierr, errmsg, overrides)
  end subroutine input_read

  !> Checks of a parsed configuration against what the run can do, before
  !> anything is allocated: the step and output counts (unless allow_long),
  !> the index space (6 unknowns a node) against index_max (the largest
  !> PetscInt), and the memory estimate against the memory the ranks' hosts
  !> have available. Collective over comm; every rank returns the same result.
  subroutine input_check_run(cfg, comm, allow_long, index_max, ierr, errmsg, ts_dt)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: comm                     !< MPI communicator of the run
    logical, intent(in) :: allow_long               !< -nuno_allow_long given
    integer(int64), intent(in) :: index_max         !< largest index (PetscInt, default integer)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp), intent(in), optional :: ts_dt         !< -ts_dt, which overrides the namelist's dt
    real(rp) :: nodes, need, per_node
    integer(int64) :: avail
    character(32) :: a, b, lim

    ierr = 0
    errmsg = ''
    ! Counts in reals: t_end/dt may exceed every integer kind.
    if (present(ts_dt)) then
      if (.not. (ts_dt > 0.0_rp .and. ts_dt <= huge(ts_dt))) then
        ierr = 1
        errmsg = 'input: -ts_dt '//fmt_real(ts_dt)//' must be a finite number > 0'
        return
      end if
    end if
    if (.not. allow_long) then
      if (present(ts_dt)) then
        if (cfg%t_end/ts_dt > max_steps) then
          ierr = 1
          errmsg = 'input: -ts_dt '//fmt_real(ts_dt)//' with &time t_end = '//fmt_real(cfg%t_end)//' is '// &
                   fmt_count(cfg%t_end/ts_dt)//' steps, more than '//fmt_count(max_steps)// &
                   ': give -nuno_allow_long to run it anyway'
          return
        end if
      else if (cfg%t_end/cfg%dt > max_steps) then
        ierr = 1
        errmsg = 'input: &time: t_end = '//fmt_real(cfg%t_end)//', dt = '//fmt_real(cfg%dt)//' is '// &
                 fmt_count(cfg%t_end/cfg%dt)//' steps, more than '//fmt_count(max_steps)// &
                 ': give -nuno_allow_long to run it anyway'
        return
      end if
      if (cfg%t_end/cfg%output_interval > max_outputs) then
        ierr = 1
        errmsg = 'input: &output: output_interval = '//fmt_real(cfg%output_interval)//' with t_end = '// &
                 fmt_real(cfg%t_end)//' is '//fmt_count(cfg%t_end/cfg%output_interval)// &
                 ' output steps, more than '//fmt_count(max_outputs)//': give -nuno_allow_long to run it anyway'
        return
      end if
    end if

    write(a, '(i0)') cfg%nx
    write(b, '(i0)') cfg%ny
    write(lim, '(i0)') index_max
    nodes = real(cfg%nx, rp)*real(cfg%ny, rp)
    if (6.0_rp*nodes > real(index_max, rp)) then
      ierr = 1
      errmsg = 'input: &lattice: nx = '//trim(a)//', ny = '//trim(b)//': 6 nx ny = '// &
               fmt_count(6.0_rp*nodes)//' unknowns exceed the index limit '//trim(lim)// &
               ' (largest PetscInt)'
      return
    end if
    per_node = merge(bytes_per_node_plain, bytes_per_node_bending, cfg%bending_code == BEND_NONE)
    need = nodes*per_node
    call memory_available(comm, avail)
    if (avail > 0) then
      if (need > real(avail, rp)) then
        ierr = 1
        errmsg = 'input: &lattice: nx = '//trim(a)//', ny = '//trim(b)//': the lattice needs about '// &
                 fmt_bytes(need)//' ('//fmt_real(per_node/1000.0_rp)//' KB a node, a lower bound) but the ranks'' '// &
                 'hosts have '//fmt_bytes(real(avail, rp))//' available'
      end if
    end if
  end subroutine input_check_run

  !> Bytes available to the run: MemAvailable of /proc/meminfo (capped by a
  !> cgroup memory limit) on each host, read by one rank per host and summed
  !> over the hosts. 0 when unknown on any host (then nothing is refused).
  subroutine memory_available(comm, avail)
    integer, intent(in) :: comm
    integer(int64), intent(out) :: avail
    integer :: node, node_rank, rank, mpierr
    integer(int64) :: mine, lo

    call MPI_Comm_rank(comm, rank, mpierr)
    call MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, rank, MPI_INFO_NULL, node, mpierr)
    call MPI_Comm_rank(node, node_rank, mpierr)
    call MPI_Comm_free(node, mpierr)
    mine = 0
    if (node_rank == 0) mine = host_memory_available()
    lo = mine
    if (node_rank /= 0) lo = huge(lo)
    call MPI_Allreduce(MPI_IN_PLACE, lo, 1, MPI_INTEGER8, MPI_MIN, comm, mpierr)
    call MPI_Allreduce(mine, avail, 1, MPI_INTEGER8, MPI_SUM, comm, mpierr)
    if (lo <= 0) avail = 0
  end subroutine memory_available

  !> This host's available memory in bytes; 0 when unknown.
  function host_memory_available() result(bytes)
    integer(int64) :: bytes
    integer(int64) :: limit, used
    character(256) :: line
    integer :: u, ios
    integer(int64) :: kb

    bytes = 0
    open(newunit=u, file='/proc/meminfo', action='read', status='old', iostat=ios)
    if (ios /= 0) return
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (line(1:13) == 'MemAvailable:') then
        read(line(14:), *, iostat=ios) kb
        if (ios == 0) bytes = kb*1024_int64
        exit
      end if
    end do
    close(u)
    ! A container's limit (cgroup v2, then v1) is what this run can use.
    if (read_int64('/sys/fs/cgroup/memory.max', limit) .and. read_int64('/sys/fs/cgroup/memory.current', used)) then
      if (bytes > 0) bytes = min(bytes, max(0_int64, limit - used))
    else if (read_int64('/sys/fs/cgroup/memory/memory.limit_in_bytes', limit) .and. &
             read_int64('/sys/fs/cgroup/memory/memory.usage_in_bytes', used)) then
      if (bytes > 0) bytes = min(bytes, max(0_int64, limit - used))
    end if
  end function host_memory_available

  !> The first integer in file `path` ('max' and unreadable files: .false.).
  logical function read_int64(path, val)
    character(*), intent(in) :: path
    integer(int64), intent(out) :: val
    integer :: u, ios
    val = 0
    read_int64 = .false.
    open(newunit=u, file=path, action='read', status='old', iostat=ios)
    if (ios /= 0) return
    read(u, *, iostat=ios) val
    close(u)
    read_int64 = ios == 0
  end function read_int64

  !> A count such as 2.2E+10 (or 11 when small), for messages.
  function fmt_count(x) result(s)
    real(rp), intent(in) :: x
    character(:), allocatable :: s
    character(32) :: buf
    if (x < 1.0e7_rp) then
      write(buf, '(i0)') nint(x)
    else if (x < 1.0e99_rp) then
      write(buf, '(es10.2e2)') x
    else
      buf = fmt_real(x)
    end if
    s = trim(adjustl(buf))
  end function fmt_count

  !> Bytes as GB/MB with three digits, for messages.
  function fmt_bytes(x) result(s)
    real(rp), intent(in) :: x
    character(:), allocatable :: s
    character(32) :: buf
    if (x >= 1.0e12_rp) then
      buf = fmt_count(x/1.0e12_rp)//' TB'
      if (x < 1.0e19_rp) write(buf, '(f0.1,a)') x/1.0e12_rp, ' TB'
    else if (x >= 1.0e9_rp) then
      write(buf, '(f0.1,a)') x/1.0e9_rp, ' GB'
    else
      write(buf, '(f0.1,a)') x/1.0e6_rp, ' MB'
    end if
    s = trim(adjustl(buf))
  end function fmt_bytes

  !> Parse namelist text (no MPI): scene, scene defaults, groups, derived values, checks.
  !> Public so that tests and tools can build a configuration from a string.
  subroutine input_parse(text, cfg, ierr, errmsg, overrides)
    character(*), intent(in) :: text           !< the whole namelist file
    type(nuno_config), intent(out) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    character(*), intent(in), optional :: overrides !< -nuno_set: key=value,... read after the file
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
    if (present(overrides)) then
      call apply_overrides(overrides, first, .true., ierr, msg)
      if (ierr /= 0) goto 900
    end if
    first%scene = lower(adjustl(first%scene))
    call check_choice('scene', 'scene', first%scene, scene_list, code, ierr, msg)
    if (ierr /= 0) goto 900

    ! 2. That scene's defaults; keys whose default depends on other keys start unset.
    call scene_defaults(code, cfg)
    cfg%k_b = unset_real
    cfg%eta_b = unset_real
    cfg%mass_distribution = ''

    ! 3. Every group over them (&scene again, so its other keys see the scene's defaults).
    call read_group(G_SCENE, pt, cfg, ierr, msg);    if (ierr /= 0) goto 900
    call read_group(G_LATTICE, pt, cfg, ierr, msg);  if (ierr /= 0) goto 900
    call read_group(G_MATERIAL, pt, cfg, ierr, msg); if (ierr /= 0) goto 900
    call read_group(G_TIME, pt, cfg, ierr, msg);     if (ierr /= 0) goto 900
    call read_group(G_OUTPUT, pt, cfg, ierr, msg);   if (ierr /= 0) goto 900
    call read_group(G_IDENTIFY, pt, cfg, ierr, msg); if (ierr /= 0) goto 900
    call read_group(G_CONTROL, pt, cfg, ierr, msg);  if (ierr /= 0) goto 900
    cfg%identify = pt%count(G_IDENTIFY) > 0
    cfg%control = pt%count(G_CONTROL) > 0
    cfg%namelist_text = text
    if (present(overrides)) then
      ! Command-line keys win over the file's; they are recorded with it.
      call apply_overrides(overrides, cfg, .false., ierr, msg)
      if (ierr /= 0) goto 900
      if (len_trim(overrides) > 0) cfg%namelist_text = text//new_line('a')//'! -nuno_set '//trim(overrides)
    end if
    cfg%scene = lower(adjustl(cfg%scene))
    cfg%scene_code = code

    ! 4. Choices to codes, lattice spacing, keys left unset, then the checks.
    call derive_codes(cfg, ierr, msg);        if (ierr /= 0) goto 900
    call check_finite_keys(cfg, ierr, msg);   if (ierr /= 0) goto 900
    call check_lattice_size(cfg, ierr, msg);  if (ierr /= 0) goto 900
    call check_lattice_extent(cfg, ierr, msg); if (ierr /= 0) goto 900
    cfg%ax = cfg%lx/real(cfg%nx - 1, rp)
    cfg%ay = cfg%ly/real(cfg%ny - 1, rp)
    call resolve_unset(cfg, ierr, msg);       if (ierr /= 0) goto 900
    cfg%has_gravity = any(cfg%gravity /= 0.0_rp)
    cfg%has_damping = cfg%eta_s > 0.0_rp .or. cfg%eta_d > 0.0_rp
    call validate(cfg, ierr, msg)

900 if (ierr /= 0) errmsg = trim(msg)
  end subroutine input_parse

  ! ==========================================================================
  ! Text preparation
  ! ==========================================================================

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

  pure logical function is_name_char(c)
    character(1), intent(in) :: c
    is_name_char = (c >= 'a' .and. c <= 'z') .or. (c >= 'A' .and. c <= 'Z') .or. &
                   (c >= '0' .and. c <= '9') .or. c == '_'
  end function is_name_char

  integer function group_index(name)
    character(*), intent(in) :: name
    integer :: g
    group_index = 0
    do g = 1, n_groups
      if (trim(name) == trim(group_names(g))) group_index = g
    end do
  end function group_index

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
    integer :: ios, ios1, p, q, nb
    character(:), allocatable :: body

    ierr = 0
    msg = ''
    if (pt%count(g) == 0) return
    iomsg = ''
    call read_nml(g, pt%lines, cfg, ios, iomsg)
    if (ios == 0) return
    ierr = 1
    msg = 'input: &'//trim(group_names(g))//': '//trim(iomsg)
    if (g == G_SCENE) call unrename_scene(msg)
    ! Which assignment? Split the body before each "name =" and try each alone.
    body = trim(pt%body(g))
    nb = len(body)
    p = next_assignment(body, 1)
    do while (p <= nb)
      q = next_assignment(body, p + 1)
      block
        character(q - p + 32) :: one(1)
        one(1) = '&'//trim(group_names(g))//' '//body(p:q - 1)//' /'
        scratch = cfg
        iomsg1 = ''
        call read_nml(g, one, scratch, ios1, iomsg1)
      end block
      if (ios1 /= 0) then
        msg = 'input: &'//trim(group_names(g))//': '//trim(iomsg1)//' (in: '// &
              trim(strip_commas(body(p:q - 1)))//')'
        if (g == G_SCENE) call unrename_scene(msg)
        return
      end if
      p = q
    end do
  end subroutine read_group

  !> -nuno_set: comma-separated assignments key=value (namelist syntax:
  !> strings quoted, arrays listed, elements by subscript), each key by its
  !> name alone (names are unique across groups) or as group%key, read over
  !> cfg as if written in its group. scene_only: apply the key `scene` only
  !> (the scene picks the defaults before the groups are read).
  subroutine apply_overrides(ov, cfg, scene_only, ierr, msg)
    character(*), intent(in) :: ov
    type(nuno_config), intent(inout) :: cfg
    logical, intent(in) :: scene_only
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(msg_len) :: iomsg
    character(:), allocatable :: a, key, base, rhs
    integer :: n, p, q, e, pc, g, ios

    ierr = 0
    msg = ''
    n = len_trim(ov)
    if (n == 0) return
    p = next_assignment(ov(1:n), 1)
    if (p > n .or. verify(ov(1:p - 1), ' ,') /= 0) then
      ierr = 1
      msg = "input: -nuno_set '"//ov(1:n)//"': expected key=value[,key=value...]"
      return
    end if
    do while (p <= n)
      q = next_assignment(ov(1:n), p + 1)
      a = trim(ov(p:q - 1))
      do while (len(a) > 0)
        if (a(len(a):len(a)) /= ',') exit
        a = trim(a(1:len(a) - 1))
      end do
      p = q
      e = index(a, '=')
      key = lower(trim(adjustl(a(1:e - 1))))
      rhs = a(e + 1:)
      pc = index(key, '%')
      if (pc > 0) then
        g = group_index(key(1:pc - 1))
        key = key(pc + 1:)
      else
        g = 0
      end if
      base = key
      if (index(base, '(') > 0) base = base(1:index(base, '(') - 1)
      if (g == 0) g = key_group(base)
      if (g == 0) then
        ierr = 1
        msg = "input: -nuno_set: unknown key '"//trim(key)//"' (in: "//a//')'
        return
      end if
      if (scene_only .and. base /= 'scene') cycle
      if (base == 'scene') key = 'scene_name'//key(6:)
      block
        character(len(a) + 32) :: line(1)
        line(1) = '&'//trim(group_names(g))//' '//key//' = '//rhs//' /'
        iomsg = ''
        call read_nml(g, line, cfg, ios, iomsg)
      end block
      if (ios /= 0) then
        ierr = 1
        msg = 'input: -nuno_set: &'//trim(group_names(g))//': '//trim(iomsg)//' (in: '//a//')'
        call unrename_scene(msg)
        return
      end if
    end do
  end subroutine apply_overrides

  !> The group of a key (0: no such key). Every key name is unique.
  integer function key_group(name) result(g)
    character(*), intent(in) :: name
    select case (name)
    case ('nx', 'ny', 'lx', 'ly', 'total_mass', 'mass_distribution', 'lattice_scaling')
      g = G_LATTICE
    case ('spring_model', 'e_s', 'eta_s', 'e_d', 'eta_d', 'bending_model', 'k_b', 'eta_b')
      g = G_MATERIAL
    case ('scene', 'gravity', 'lift_length', 'lift_height', 'bend_angle', 'n_keyframes', &
          'keyframe_time', 'keyframe_dx', 'keyframe_dy', 'keyframe_dz', 'wave_nodes', 'release_time', &
          'initial_omega')
      g = G_SCENE
    case ('t_end', 'dt')
      g = G_TIME
    case ('output_interval', 'write_velocity', 'output_file', 'petsc_options', 'stretch_limit', 'checkpoint_interval')
      g = G_OUTPUT
    case ('observed_file', 'fit', 'fit_lower', 'fit_upper', 'tikhonov')
      g = G_IDENTIFY
    case ('target_file', 'components', 'max_speed', 'velocity_weight', 'keyframe_tikhonov')
      g = G_CONTROL
    case default
      g = 0
    end select
  end function key_group

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

  !> An assignment without blanks and commas at its ends.
  function strip_commas(s) result(r)
    character(*), intent(in) :: s
    character(:), allocatable :: r
    integer :: e
    r = trim(adjustl(s))
    e = len(r)
    do while (e > 0)
      if (r(e:e) /= ',' .and. r(e:e) /= ' ') exit
      e = e - 1
    end do
    r = r(1:e)
  end function strip_commas

  !> One namelist READ of group g from the records `lines`, over cfg.
  subroutine read_nml(g, lines, cfg, ios, iomsg)
    integer, intent(in) :: g
    character(*), intent(in) :: lines(:)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ios
    character(*), intent(inout) :: iomsg
    ! Namelist objects must be variables: locals named after the keys.
    integer :: nx, ny
    real(rp) :: lx, ly, total_mass
    character(label_len) :: mass_distribution, lattice_scaling
    character(label_len) :: spring_model, bending_model
    real(rp) :: e_s, eta_s, e_d, eta_d, k_b, eta_b
    character(label_len) :: scene_name   ! the key `scene` (renamed by scan_text)
    real(rp) :: gravity(3), lift_length, lift_height, bend_angle
    integer :: n_keyframes
    real(rp) :: keyframe_time(keyframe_max), keyframe_dx(keyframe_max), keyframe_dy(keyframe_max), &
                keyframe_dz(keyframe_max)
    character(label_len) :: wave_nodes
    real(rp) :: release_time, initial_omega(3)
    real(rp) :: t_end, dt
    real(rp) :: output_interval, stretch_limit, checkpoint_interval
    logical :: write_velocity
    character(path_len) :: output_file
    character(len(cfg%petsc_options)) :: petsc_options
    namelist /lattice/ nx, ny, lx, ly, total_mass, mass_distribution, lattice_scaling
    namelist /material/ spring_model, e_s, eta_s, e_d, eta_d, bending_model, k_b, eta_b
    namelist /scene/ scene_name, gravity, lift_length, lift_height, bend_angle, n_keyframes, &
                     keyframe_time, keyframe_dx, keyframe_dy, keyframe_dz, wave_nodes, release_time, initial_omega
    namelist /time/ t_end, dt
    namelist /output/ output_interval, write_velocity, output_file, petsc_options, stretch_limit, &
                      checkpoint_interval
    character(path_len) :: observed_file
    character(len(cfg%fit)) :: fit
    real(rp) :: fit_lower(n_fit_kinds), fit_upper(n_fit_kinds), tikhonov
    namelist /identify/ observed_file, fit, fit_lower, fit_upper, tikhonov
    character(path_len) :: target_file
    character(label_len) :: components
    real(rp) :: max_speed, velocity_weight, keyframe_tikhonov
    namelist /control/ target_file, components, max_speed, velocity_weight, keyframe_tikhonov

    ios = 0
    select case (g)
    case (G_LATTICE)
      nx = cfg%nx; ny = cfg%ny; lx = cfg%lx; ly = cfg%ly; total_mass = cfg%total_mass
      mass_distribution = cfg%mass_distribution; lattice_scaling = cfg%lattice_scaling
      read(lines, nml=lattice, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
      cfg%nx = nx; cfg%ny = ny; cfg%lx = lx; cfg%ly = ly; cfg%total_mass = total_mass
      cfg%mass_distribution = mass_distribution; cfg%lattice_scaling = lattice_scaling
      end if
    case (G_MATERIAL)
      spring_model = cfg%spring_model; e_s = cfg%e_s; eta_s = cfg%eta_s; e_d = cfg%e_d
      eta_d = cfg%eta_d; bending_model = cfg%bending_model; k_b = cfg%k_b; eta_b = cfg%eta_b
      read(lines, nml=material, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
      cfg%spring_model = spring_model; cfg%e_s = e_s; cfg%eta_s = eta_s; cfg%e_d = e_d
      cfg%eta_d = eta_d; cfg%bending_model = bending_model; cfg%k_b = k_b; cfg%eta_b = eta_b
      end if
    case (G_SCENE)
      scene_name = cfg%scene; gravity = cfg%gravity; lift_length = cfg%lift_length
      lift_height = cfg%lift_height; bend_angle = cfg%bend_angle; n_keyframes = cfg%n_keyframes
      keyframe_time = cfg%keyframe_time; keyframe_dz = cfg%keyframe_dz; wave_nodes = cfg%wave_nodes
      keyframe_dx = cfg%keyframe_dx; keyframe_dy = cfg%keyframe_dy
      release_time = cfg%release_time; initial_omega = cfg%initial_omega
      read(lines, nml=scene, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
      cfg%scene = scene_name; cfg%gravity = gravity; cfg%lift_length = lift_length
      cfg%lift_height = lift_height; cfg%bend_angle = bend_angle; cfg%n_keyframes = n_keyframes
      cfg%keyframe_time = keyframe_time; cfg%keyframe_dz = keyframe_dz; cfg%wave_nodes = wave_nodes
      cfg%keyframe_dx = keyframe_dx; cfg%keyframe_dy = keyframe_dy
      cfg%release_time = release_time; cfg%initial_omega = initial_omega
      end if
    case (G_TIME)
      t_end = cfg%t_end; dt = cfg%dt
      read(lines, nml=time, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
        cfg%t_end = t_end; cfg%dt = dt
      end if
    case (G_OUTPUT)
      output_interval = cfg%output_interval; write_velocity = cfg%write_velocity
      output_file = cfg%output_file; petsc_options = cfg%petsc_options
      stretch_limit = cfg%stretch_limit; checkpoint_interval = cfg%checkpoint_interval
      read(lines, nml=output, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
      cfg%output_interval = output_interval; cfg%write_velocity = write_velocity
      cfg%output_file = output_file; cfg%petsc_options = petsc_options
      cfg%stretch_limit = stretch_limit; cfg%checkpoint_interval = checkpoint_interval
      end if
    case (G_IDENTIFY)
      observed_file = cfg%observed_file; fit = cfg%fit; fit_lower = cfg%fit_lower
      fit_upper = cfg%fit_upper; tikhonov = cfg%tikhonov
      read(lines, nml=identify, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
        cfg%observed_file = observed_file; cfg%fit = fit; cfg%fit_lower = fit_lower
        cfg%fit_upper = fit_upper; cfg%tikhonov = tikhonov
      end if
    case (G_CONTROL)
      target_file = cfg%target_file; components = cfg%components; max_speed = cfg%max_speed
      velocity_weight = cfg%velocity_weight; keyframe_tikhonov = cfg%keyframe_tikhonov
      read(lines, nml=control, iostat=ios, iomsg=iomsg)
      if (ios == 0) then
        cfg%target_file = target_file; cfg%components = components; cfg%max_speed = max_speed
        cfg%velocity_weight = velocity_weight; cfg%keyframe_tikhonov = keyframe_tikhonov
      end if
    end select
    ! gfortran may report an end of file with iostat < 0: the group is known
    ! to be present and closed, so any non-zero status is an error.
    if (ios /= 0) then
      if (len_trim(iomsg) == 0) iomsg = 'read error'
      call reset_list_state()
    end if
  end subroutine read_nml

  !> libgfortran 12 keeps state after a failed namelist read (e.g. a bad
  !> logical: 'Bad repeat count'), and the next namelist read then succeeds
  !> wrongly; any list-directed read clears it.
  subroutine reset_list_state()
    character(1) :: one
    integer :: i, ios
    one = '0'
    read(one, *, iostat=ios) i
  end subroutine reset_list_state

  ! ==========================================================================
  ! Scene defaults and derived values
  ! ==========================================================================

  !> Defaults of scene `code` (docs/model.md section 7) over the plain defaults.
  !> Report scenes: mm, g, s; E = eta = 1 per link; paper bending k_b = 1.
  subroutine scene_defaults(code, cfg)
    integer, intent(in) :: code
    type(nuno_config), intent(inout) :: cfg
    type(nuno_config) :: plain

    cfg = plain
    ! Common to the report scenes (and flat).
    cfg%nx = 11; cfg%ny = 11
    cfg%lx = 100.0_rp; cfg%ly = 100.0_rp
    cfg%total_mass = 1.0_rp
    cfg%mass_distribution = 'uniform'
    cfg%lattice_scaling = 'element'
    cfg%spring_model = 'axial'
    cfg%e_s = 1.0_rp; cfg%eta_s = 1.0_rp; cfg%e_d = 1.0_rp; cfg%eta_d = 1.0_rp
    cfg%bending_model = 'paper'
    cfg%gravity = 0.0_rp
    cfg%lift_length = 30.0_rp; cfg%lift_height = 15.0_rp
    cfg%bend_angle = 30.0_rp
    cfg%n_keyframes = 3
    cfg%keyframe_time = 0.0_rp; cfg%keyframe_dx = 0.0_rp; cfg%keyframe_dy = 0.0_rp; cfg%keyframe_dz = 0.0_rp
    cfg%keyframe_time(1:3) = [0.0_rp, 0.5_rp, 1.0_rp]
    cfg%keyframe_dz(1:3) = [0.0_rp, -10.0_rp, 15.0_rp]
    cfg%release_time = huge(1.0_rp)
    cfg%initial_omega = 0.0_rp
    cfg%t_end = 5.0_rp; cfg%dt = 1.0e-3_rp
    cfg%output_interval = 0.02_rp
    cfg%write_velocity = .false.
    cfg%petsc_options = ''
    select case (code)
    case (SCENE_LIFT_RELEASE)
      cfg%scene = 'lift_release'
      cfg%output_file = 'lift_release.h5'
    case (SCENE_BEND_RELEASE)
      cfg%scene = 'bend_release'
      cfg%lx = 50.0_rp; cfg%ly = 50.0_rp
      cfg%total_mass = 0.25_rp
      cfg%output_file = 'bend_release.h5'
    case (SCENE_WAVE_POINT)
      cfg%scene = 'wave_point'
      cfg%bending_model = 'none'
      cfg%t_end = 3.0_rp
      cfg%output_file = 'wave_point.h5'
    case (SCENE_HANG)
      cfg%scene = 'hang'
      cfg%nx = 21; cfg%ny = 21
      cfg%lx = 1.0_rp; cfg%ly = 1.0_rp
      cfg%total_mass = 0.1_rp
      cfg%mass_distribution = 'area'
      cfg%e_s = 100.0_rp; cfg%eta_s = 0.1_rp; cfg%e_d = 100.0_rp; cfg%eta_d = 0.1_rp
      cfg%bending_model = 'energy'
      cfg%gravity = [0.0_rp, 0.0_rp, -9.81_rp]
      cfg%t_end = 2.0_rp; cfg%dt = 1.0e-3_rp
      cfg%output_interval = 0.05_rp
      cfg%output_file = 'hang.h5'
    case (SCENE_FLAT)
      cfg%scene = 'flat'
      cfg%t_end = 1.0_rp
      cfg%output_interval = 0.1_rp
      cfg%output_file = 'flat.h5'
    end select
    cfg%scene_code = code
  end subroutine scene_defaults

  !> String choices to integer codes.
  subroutine derive_codes(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    cfg%lattice_scaling = lower(adjustl(cfg%lattice_scaling))
    cfg%mass_distribution = lower(adjustl(cfg%mass_distribution))
    cfg%spring_model = lower(adjustl(cfg%spring_model))
    cfg%bending_model = lower(adjustl(cfg%bending_model))
    cfg%wave_nodes = lower(adjustl(cfg%wave_nodes))
    call check_choice('lattice', 'lattice_scaling', cfg%lattice_scaling, 'element, continuum', &
                      cfg%scaling_code, ierr, msg)
    if (ierr /= 0) return
    if (len_trim(cfg%mass_distribution) == 0) then
      ! Unset: the continuum mode needs area masses; else the scene's default.
      if (cfg%scaling_code == SCALING_CONTINUUM .or. cfg%scene_code == SCENE_HANG) then
        cfg%mass_distribution = 'area'
      else
        cfg%mass_distribution = 'uniform'
      end if
    end if
    call check_choice('lattice', 'mass_distribution', cfg%mass_distribution, 'uniform, area', &
                      cfg%mass_code, ierr, msg)
    if (ierr /= 0) return
    call check_choice('material', 'spring_model', cfg%spring_model, 'axial, linear', &
                      cfg%spring_code, ierr, msg)
    if (ierr /= 0) return
    call check_choice('material', 'bending_model', cfg%bending_model, 'none, paper, energy', &
                      cfg%bending_code, ierr, msg)
    if (ierr /= 0) return
    cfg%bending_code = cfg%bending_code - 1   ! list order none, paper, energy = 0, 1, 2
  end subroutine derive_codes

  !> Keys left unset take defaults that depend on other keys:
  !> k_b: the scene's value in the chosen model, converted between a force per
  !> radian (paper) and an energy (energy) by the link length ax (docs/model.md 3);
  !> eta_b: 1e-4 for hang with energy bending, else 0.
  subroutine resolve_unset(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    real(rp) :: kb_paper, kb_energy
    ierr = 0
    msg = ''
    if (cfg%scene_code == SCENE_HANG) then
      kb_energy = 0.1_rp
      kb_paper = kb_energy/cfg%ax
    else
      kb_paper = 1.0_rp
      kb_energy = kb_paper*cfg%ax
    end if
    if (cfg%k_b == unset_real) then
      select case (cfg%bending_code)
      case (BEND_PAPER);  cfg%k_b = kb_paper
      case (BEND_ENERGY); cfg%k_b = kb_energy
      case default;       cfg%k_b = 0.0_rp
      end select
    end if
    if (cfg%eta_b == unset_real) then
      cfg%eta_b = 0.0_rp
      if (cfg%scene_code == SCENE_HANG .and. cfg%bending_code == BEND_ENERGY) cfg%eta_b = 1.0e-4_rp
    end if
  end subroutine resolve_unset

  ! ==========================================================================
  ! Checks: one routine per concern; the first error wins
  ! ==========================================================================

  subroutine validate(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call check_mass(cfg, ierr, msg);           if (ierr /= 0) return
    call check_material(cfg, ierr, msg);       if (ierr /= 0) return
    call check_scaling_bending(cfg, ierr, msg); if (ierr /= 0) return
    call check_scene_geometry(cfg, ierr, msg); if (ierr /= 0) return
    call check_keyframes(cfg, ierr, msg);      if (ierr /= 0) return
    call check_wave_nodes(cfg, ierr, msg);     if (ierr /= 0) return
    call check_time(cfg, ierr, msg);           if (ierr /= 0) return
    call check_output(cfg, ierr, msg);         if (ierr /= 0) return
    call check_identify(cfg, ierr, msg);       if (ierr /= 0) return
    call check_control(cfg, ierr, msg)
  end subroutine validate

  !> &identify: known, distinct parameter names, each with an initial guess
  !> > 0 (fitted in log space) inside its bounds; a model that has the
  !> parameter; an observed file named. The names go to cfg%fit_code.
  subroutine check_identify(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(:), allocatable :: rest, name
    integer :: p, k, code
    real(rp) :: p0

    ierr = 0
    msg = ''
    cfg%n_fit = 0
    if (.not. cfg%identify) return
    ierr = 1
    if (len_trim(cfg%observed_file) == 0) then
      msg = "input: &identify: observed_file is required (an HDF5 file with /time and /position [nt][ny][nx][3])"
      return
    end if
    rest = lower(trim(adjustl(cfg%fit)))
    if (len(rest) == 0) then
      msg = 'input: &identify: fit is required: a comma-separated list of '//kinds_list()
      return
    end if
    do while (len(rest) > 0)
      p = index(rest, ',')
      if (p == 0) p = len(rest) + 1
      name = trim(adjustl(rest(1:p - 1)))
      rest = trim(adjustl(rest(min(p + 1, len(rest) + 1):)))
      code = 0
      do k = 1, n_fit_kinds
        if (name == trim(fit_kind_names(k))) code = k
      end do
      if (code == 0) then
        msg = "input: &identify: fit: unknown parameter '"//name//"' (known: "//kinds_list()//')'
        return
      end if
      if (any(cfg%fit_code(1:cfg%n_fit) == code)) then
        msg = "input: &identify: fit: '"//name//"' is named twice"
        return
      end if
      cfg%n_fit = cfg%n_fit + 1
      cfg%fit_code(cfg%n_fit) = code
      if ((code == 5 .or. code == 6) .and. cfg%bending_code == BEND_NONE) then
        msg = "input: &identify: fit: '"//name//"' needs bending (&material bending_model = 'none')"
        return
      end if
      if (code == 6 .and. cfg%bending_code /= BEND_ENERGY) then
        msg = "input: &identify: fit: 'eta_b' exists only with bending_model = 'energy'"
        return
      end if
      p0 = fit_initial(cfg, code)
      if (.not. (p0 > 0.0_rp)) then
        msg = "input: &identify: fit: '"//name//"' = "//fmt_real(p0)//' cannot be fitted: parameters are '// &
              'fitted in log space, so the initial guess (the namelist value) must be > 0'
        return
      end if
      k = cfg%n_fit
      if (cfg%fit_lower(k) == unset_real) cfg%fit_lower(k) = p0 / 1000.0_rp
      if (cfg%fit_upper(k) == unset_real) cfg%fit_upper(k) = p0 * 1000.0_rp
      if (.not. (cfg%fit_lower(k) > 0.0_rp .and. cfg%fit_lower(k) <= p0 .and. p0 <= cfg%fit_upper(k))) then
        msg = "input: &identify: the bounds of '"//name//"' must satisfy 0 < fit_lower <= initial guess <= "// &
              'fit_upper (got '//fmt_real(cfg%fit_lower(k))//' <= '//fmt_real(p0)//' <= '//fmt_real(cfg%fit_upper(k))//')'
        return
      end if
    end do
    if (.not. (cfg%tikhonov >= 0.0_rp)) then
      msg = 'input: &identify: tikhonov must be >= 0 (got '//fmt_real(cfg%tikhonov)//')'
      return
    end if
    ierr = 0
  contains
    function kinds_list() result(s)
      character(:), allocatable :: s
      integer :: m
      s = trim(fit_kind_names(1))
      do m = 2, n_fit_kinds
        s = s//', '//trim(fit_kind_names(m))
      end do
    end function kinds_list
  end subroutine check_identify

  !> &control: not with &identify; a target file; a scene with keyframed
  !> nodes and at least two keyframes (the steps between them are what is
  !> optimised); components letters of xyz, each once; max_speed > 0 when
  !> set, and the initial keyframes within it; weights >= 0. The letters go
  !> to cfg%control_comp.
  subroutine check_control(cfg, ierr, msg)
    type(nuno_config), intent(inout) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(*), parameter :: xyz = 'xyz'
    character(len=:), allocatable :: comps
    real(rp) :: off(3, keyframe_max), dt, speed
    integer :: k, c, m
    character(16) :: a, b

    ierr = 0
    msg = ''
    cfg%control_comp = .false.
    if (.not. cfg%control) return
    ierr = 1
    if (cfg%identify) then
      msg = 'input: &control and &identify cannot be in one input: a run either fits the model to an '// &
            'observation or optimises the keyframes for a target'
      return
    end if
    if (len_trim(cfg%target_file) == 0) then
      msg = 'input: &control: target_file is required (an HDF5 file with /time and /position [nt][ny][nx][3])'
      return
    end if
    if (cfg%scene_code /= SCENE_WAVE_POINT) then
      msg = "input: &control: scene = '"//trim(cfg%scene)//"' has no nodes on a keyframe path to control "// &
            "(wave_point drives its corner or, with wave_nodes = 'edge', its edge i = 0)"
      return
    end if
    if (cfg%n_keyframes < 2) then
      write(a, '(i0)') cfg%n_keyframes
      msg = 'input: &control: &scene n_keyframes = '//trim(a)//' leaves nothing to optimise: the steps '// &
            'between consecutive keyframes are the controls, so at least 2 keyframes are needed'
      return
    end if
    comps = lower(trim(adjustl(cfg%components)))
    if (len(comps) == 0 .or. verify(comps, xyz) /= 0) then
      msg = "input: &control: components = '"//trim(cfg%components)//"' must be letters among x, y, z (e.g. 'z' or 'xyz')"
      return
    end if
    do k = 1, len(comps)
      c = index(xyz, comps(k:k))
      if (cfg%control_comp(c)) then
        msg = "input: &control: components = '"//trim(cfg%components)//"' names "//comps(k:k)//' twice'
        return
      end if
      cfg%control_comp(c) = .true.
    end do
    if (cfg%max_speed /= unset_real) then
      call need_positive('control', 'max_speed', cfg%max_speed, ierr, msg)
      if (ierr /= 0) return
      ierr = 1
      off(1, :) = cfg%keyframe_dx
      off(2, :) = cfg%keyframe_dy
      off(3, :) = cfg%keyframe_dz
      do m = 2, cfg%n_keyframes
        dt = cfg%keyframe_time(m) - cfg%keyframe_time(m - 1)
        do c = 1, 3
          if (.not. cfg%control_comp(c)) cycle
          speed = abs(off(c, m) - off(c, m - 1)) / dt
          if (speed > cfg%max_speed * (1.0_rp + 1.0e-12_rp)) then
            write(a, '(i0)') m
            write(b, '(i0)') m - 1
            msg = 'input: &control: the initial keyframes exceed max_speed = '//fmt_real(cfg%max_speed)// &
                  ': keyframe_d'//xyz(c:c)//'('//trim(a)//') - keyframe_d'//xyz(c:c)//'('//trim(b)//') = '// &
                  fmt_real(off(c, m) - off(c, m - 1))//' in '//fmt_real(dt)//' is a speed of '//fmt_real(speed)
            return
          end if
        end do
      end do
    end if
    call need_nonnegative('control', 'velocity_weight', cfg%velocity_weight, ierr, msg); if (ierr /= 0) return
    call need_nonnegative('control', 'keyframe_tikhonov', cfg%keyframe_tikhonov, ierr, msg)
  end subroutine check_control

  !> The namelist value of fit parameter `code` (the initial guess).
  pure real(rp) function fit_initial(cfg, code)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: code
    select case (code)
    case (1); fit_initial = cfg%e_s
    case (2); fit_initial = cfg%e_d
    case (3); fit_initial = cfg%eta_s
    case (4); fit_initial = cfg%eta_d
    case (5); fit_initial = cfg%k_b
    case (6); fit_initial = cfg%eta_b
    case default; fit_initial = cfg%total_mass
    end select
  end function fit_initial

  !> Every real key finite: NaN or Inf would pass some range checks (a NaN
  !> compares false both ways) and run, writing NaN into the output.
  subroutine check_finite_keys(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    call fin('lattice', 'lx', [cfg%lx]);                if (ierr /= 0) return
    call fin('lattice', 'ly', [cfg%ly]);                if (ierr /= 0) return
    call fin('lattice', 'total_mass', [cfg%total_mass]); if (ierr /= 0) return
    call fin('material', 'e_s', [cfg%e_s]);             if (ierr /= 0) return
    call fin('material', 'eta_s', [cfg%eta_s]);         if (ierr /= 0) return
    call fin('material', 'e_d', [cfg%e_d]);             if (ierr /= 0) return
    call fin('material', 'eta_d', [cfg%eta_d]);         if (ierr /= 0) return
    call fin('material', 'k_b', [cfg%k_b]);             if (ierr /= 0) return
    call fin('material', 'eta_b', [cfg%eta_b]);         if (ierr /= 0) return
    call fin('scene', 'gravity', cfg%gravity);          if (ierr /= 0) return
    call fin('scene', 'lift_length', [cfg%lift_length]); if (ierr /= 0) return
    call fin('scene', 'lift_height', [cfg%lift_height]); if (ierr /= 0) return
    call fin('scene', 'bend_angle', [cfg%bend_angle]);  if (ierr /= 0) return
    call fin('scene', 'keyframe_time', cfg%keyframe_time); if (ierr /= 0) return
    call fin('scene', 'keyframe_dx', cfg%keyframe_dx);  if (ierr /= 0) return
    call fin('scene', 'keyframe_dy', cfg%keyframe_dy);  if (ierr /= 0) return
    call fin('scene', 'keyframe_dz', cfg%keyframe_dz);  if (ierr /= 0) return
    call fin('scene', 'release_time', [cfg%release_time]); if (ierr /= 0) return
    call fin('scene', 'initial_omega', cfg%initial_omega); if (ierr /= 0) return
    call fin('time', 't_end', [cfg%t_end]);             if (ierr /= 0) return
    call fin('time', 'dt', [cfg%dt]);                   if (ierr /= 0) return
    call fin('output', 'output_interval', [cfg%output_interval]); if (ierr /= 0) return
    call fin('output', 'stretch_limit', [cfg%stretch_limit]); if (ierr /= 0) return
    call fin('output', 'checkpoint_interval', [cfg%checkpoint_interval]); if (ierr /= 0) return
    call fin('control', 'max_speed', [cfg%max_speed]);  if (ierr /= 0) return
    call fin('control', 'velocity_weight', [cfg%velocity_weight]); if (ierr /= 0) return
    call fin('control', 'keyframe_tikhonov', [cfg%keyframe_tikhonov])
  contains
    !> Arrays are named with the subscript of the first bad element.
    subroutine fin(group, key, values)
      character(*), intent(in) :: group, key
      real(rp), intent(in) :: values(:)
      character(16) :: sub
      integer :: k
      do k = 1, size(values)
        if (.not. (abs(values(k)) <= huge(values(k)))) then
          ierr = 1
          sub = ''
          if (size(values) > 1) write(sub, '(a,i0,a)') '(', k, ')'
          msg = 'input: &'//group//': '//key//trim(sub)//' = '//fmt_real(values(k))// &
                ' must be a finite number'
          return
        end if
      end do
    end subroutine fin
  end subroutine check_finite_keys

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
      q = index(allowed(p:), ',')
      if (q == 0) then
        q = len(allowed) + 1
      else
        q = p + q - 1
      end if
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

  subroutine check_lattice_size(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_int_ge('lattice', 'nx', cfg%nx, 3, ierr, msg); if (ierr /= 0) return
    call need_int_ge('lattice', 'ny', cfg%ny, 3, ierr, msg)
  end subroutine check_lattice_size

  subroutine check_lattice_extent(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_positive('lattice', 'lx', cfg%lx, ierr, msg); if (ierr /= 0) return
    call need_positive('lattice', 'ly', cfg%ly, ierr, msg)
  end subroutine check_lattice_extent

  subroutine check_mass(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_positive('lattice', 'total_mass', cfg%total_mass, ierr, msg)
  end subroutine check_mass

  subroutine check_material(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_nonnegative('material', 'e_s', cfg%e_s, ierr, msg);     if (ierr /= 0) return
    call need_nonnegative('material', 'eta_s', cfg%eta_s, ierr, msg); if (ierr /= 0) return
    call need_nonnegative('material', 'e_d', cfg%e_d, ierr, msg);     if (ierr /= 0) return
    call need_nonnegative('material', 'eta_d', cfg%eta_d, ierr, msg); if (ierr /= 0) return
    call need_nonnegative('material', 'k_b', cfg%k_b, ierr, msg);     if (ierr /= 0) return
    call need_nonnegative('material', 'eta_b', cfg%eta_b, ierr, msg)
  end subroutine check_material

  !> The paper bending force does not scale with the spacing: no continuum limit.
  subroutine check_scaling_bending(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    ierr = 0
    msg = ''
    if (cfg%scaling_code == SCALING_CONTINUUM .and. cfg%bending_code == BEND_PAPER) then
      ierr = 1
      msg = "input: &material: bending_model = 'paper' has no continuum limit: " // &
            "not allowed with &lattice lattice_scaling = 'continuum' (use 'energy' or 'none')"
    else if (cfg%scaling_code == SCALING_CONTINUUM .and. cfg%mass_code /= MASS_AREA) then
      ierr = 1
      msg = "input: &lattice: mass_distribution = '"//trim(cfg%mass_distribution)// &
            "' not allowed with lattice_scaling = 'continuum' (needs 'area')"
    end if
  end subroutine check_scaling_bending

  !> Geometry keys of the scene in use; the others are not used and not checked.
  subroutine check_scene_geometry(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: i_fold
    real(rp) :: flap
    ierr = 0
    msg = ''
    if (.not. (cfg%release_time >= 0.0_rp)) then
      ierr = 1
      msg = 'input: &scene: release_time = '//fmt_real(cfg%release_time)//' must be >= 0'
      return
    end if
    select case (cfg%scene_code)
    case (SCENE_LIFT_RELEASE)
      call need_positive('scene', 'lift_length', cfg%lift_length, ierr, msg); if (ierr /= 0) return
      call need_nonnegative('scene', 'lift_height', cfg%lift_height, ierr, msg); if (ierr /= 0) return
      ! The fold line is the node column nearest to x = lx - lift_length.
      i_fold = nint((cfg%lx - cfg%lift_length)/cfg%ax)
      if (i_fold < 0 .or. i_fold >= cfg%nx - 1) then
        ierr = 1
        msg = 'input: &scene: lift_length = '//fmt_real(cfg%lift_length)// &
              ' leaves no part to lift (must lie between ax/2 and lx)'
        return
      end if
      flap = cfg%lx - real(i_fold, rp)*cfg%ax
      if (cfg%lift_height > flap*(1.0_rp + 1.0e-12_rp)) then
        ierr = 1
        msg = 'input: &scene: lift_height = '//fmt_real(cfg%lift_height)// &
              ' must be <= the length of the lifted part ('//fmt_real(flap)//')'
      end if
    case (SCENE_BEND_RELEASE)
      if (.not. (cfg%bend_angle >= 0.0_rp .and. cfg%bend_angle < 360.0_rp)) then
        ierr = 1
        msg = 'input: &scene: bend_angle = '//fmt_real(cfg%bend_angle)//' must be in [0, 360) degrees'
      end if
    end select
  end subroutine check_scene_geometry

  subroutine check_keyframes(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(16) :: a, b
    integer :: k
    ierr = 0
    msg = ''
    if (cfg%n_keyframes < 1 .or. cfg%n_keyframes > keyframe_max) then
      ierr = 1
      write(a, '(i0)') cfg%n_keyframes
      write(b, '(i0)') keyframe_max
      msg = 'input: &scene: n_keyframes = '//trim(a)//' must be in 1..'//trim(b)
      return
    end if
    if (.not. (cfg%keyframe_time(1) >= 0.0_rp)) then
      ierr = 1
      msg = 'input: &scene: keyframe_time(1) = '//fmt_real(cfg%keyframe_time(1))//' must be >= 0'
      return
    end if
    do k = 2, cfg%n_keyframes
      if (.not. (cfg%keyframe_time(k) > cfg%keyframe_time(k - 1))) then
        ierr = 1
        write(a, '(i0)') k
        write(b, '(i0)') k - 1
        msg = 'input: &scene: keyframe_time('//trim(a)//') = '//fmt_real(cfg%keyframe_time(k))// &
              ' must be > keyframe_time('//trim(b)//') = '//fmt_real(cfg%keyframe_time(k - 1))// &
              ' (strictly increasing)'
        return
      end if
    end do
  end subroutine check_keyframes

  !> wave_point's driven nodes: the corner (0,0) or the whole edge i = 0.
  subroutine check_wave_nodes(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    integer :: code
    call check_choice('scene', 'wave_nodes', cfg%wave_nodes, 'corner, edge', code, ierr, msg)
  end subroutine check_wave_nodes

  subroutine check_time(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_positive('time', 't_end', cfg%t_end, ierr, msg); if (ierr /= 0) return
    call need_positive('time', 'dt', cfg%dt, ierr, msg)
  end subroutine check_time

  subroutine check_output(cfg, ierr, msg)
    type(nuno_config), intent(in) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call need_positive('output', 'output_interval', cfg%output_interval, ierr, msg)
    if (ierr /= 0) return
    if (cfg%stretch_limit /= 0.0_rp .and. .not. cfg%stretch_limit > 1.0_rp) then
      ierr = 1
      msg = 'input: &output: stretch_limit = '//fmt_real(cfg%stretch_limit)//' must be > 1 (or 0: no warning)'
      return
    end if
    if (cfg%checkpoint_interval < 0.0_rp) then
      ierr = 1
      msg = 'input: &output: checkpoint_interval = '//fmt_real(cfg%checkpoint_interval)// &
            ' must be >= 0 (0: a checkpoint at the end of the run only)'
      return
    end if
    if (len_trim(cfg%output_file) == 0) then
      ierr = 1
      msg = "input: &output: output_file = '' must not be empty"
    end if
  end subroutine check_output

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
      msg = 'input: &'//group//': '//key//' = '//fmt_real(value)//' must be > 0'
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
      msg = 'input: &'//group//': '//key//' = '//fmt_real(value)//' must be >= 0'
    end if
  end subroutine need_nonnegative

  ! ==========================================================================
  ! Help and summary
  ! ==========================================================================

  !> Write the `nuno --help` text.
  subroutine input_usage(unit)
    integer, intent(in) :: unit
    write(unit, '(a)') 'usage: mpirun -n P nuno INPUT.nml [PETSc options]', &
      '       nuno --help', &
      '', &
      'nuno integrates an implicit mass-spring cloth: an nx x ny lattice of mass points', &
      'joined by Voigt elements (spring + dashpot) to their 8 neighbours, with bending', &
      '(the report''s "paper" model or the energy-based "energy" model), gravity and', &
      'pinned or prescribed nodes, in time with PETSc TS on a DMDA split in strips of', &
      'rows over P ranks. Results go to one HDF5 file with an XDMF file beside it.', &
      'The run writes OUTPUT.partial, locked against a second writer (OUTPUT.lock), and', &
      'renames it onto OUTPUT after its first successful step: a run that fails at', &
      'start-up leaves an earlier OUTPUT as it was. OUTPUT may not be the input file.', &
      '', &
      'INPUT.nml holds Fortran namelist groups, each optional, each at most once, and', &
      'nothing else but blanks and ! comments (an empty file or stray text is an error):', &
      '  &scene     scene name (lift_release, bend_release, wave_point, hang, flat),', &
      '             gravity, scene geometry, keyframes, release time, initial spin', &
      '  &lattice   nx, ny, lx, ly, total_mass, mass_distribution, lattice_scaling', &
      '  &material  spring_model, e_s, eta_s, e_d, eta_d, bending_model, k_b, eta_b', &
      '  &time      t_end, dt', &
      '  &output    output_interval, write_velocity, output_file, petsc_options, stretch_limit,', &
      '             checkpoint_interval', &
      '  &identify  observed_file, fit, fit_lower, fit_upper, tikhonov: fit parameters to an', &
      '             observed motion (docs/identification.md); -identify_check_gradient', &
      '             prints the adjoint gradient against central differences and stops', &
      '  &control   target_file, components, max_speed, velocity_weight, keyframe_tikhonov:', &
      '             optimise the keyframes of the driven nodes so that the cloth reaches the', &
      '             target (docs/identification.md); -control_check_gradient as above', &
      'The scene sets the defaults of every other key. Every key, its unit and its', &
      'default: input/README.md; ready-made inputs: input/*.nml. Real keys must be', &
      'finite (no NaN, Inf); a lattice beyond the index range or the memory of the', &
      'ranks'' hosts (5.7 KB a node with bending, 3 KB without) is refused.', &
      '', &
      'Input checks:', &
      '  -nuno_allow_long                             run even with more than 1e8 steps (t_end/dt) or', &
      '                                               1e5 output steps (t_end/output_interval)', &
      '', &
      'Checkpoints and restart (input/README.md, "Checkpoints and restart"):', &
      '  -nuno_restart FILE                           continue the run in FILE from its last checkpoint,', &
      '                                               appending to its series (t_end may be later)', &
      '  -nuno_checkpoint_walltime D                  a checkpoint after each D of wall-clock time', &
      '                                               (seconds, 90m, 23h, 1d or H:MM:SS); one is always', &
      '                                               written at the end, on SIGTERM/SIGINT and every', &
      '                                               checkpoint_interval (&output)', &
      '', &
      'Namelist keys from the command line (sweeps without copying files):', &
      '  -nuno_set key=value[,key=value...]           over the file''s values, same checks; a key by its', &
      '                                               name or as group%key; strings quoted, e.g.', &
      '                                               -nuno_set "nx=257,ny=257,output_file=''h257.h5''"', &
      '                                               (recorded in the output''s namelist attribute)', &
      '', &
      'PETSc options (petsc_options in &output; the command line overrides them):', &
      '  -ts_type beuler|theta|cn|bdf|arkimex|rosw   integrator (default: backward Euler, the report''s, with', &
      '                                               the namelist''s fixed dt)', &
      '  -ts_adapt_type basic -ts_rtol R -ts_atol A  adaptive steps with error control; without -ts_type they', &
      '                                               use rosw (Rosenbrock-W ra34pw2, the fastest at moderate', &
      '                                               tolerance in docs/workprecision.md)', &
      '  -nuno_adaptive_ts_type T                     that default TS type of adaptive runs (default rosw)', &
      '  -nuno_atol_position A                        absolute tolerance of positions [length] (default', &
      '                                               -ts_atol, else R times the cloth size max(lx, ly))', &
      '  -nuno_atol_velocity B                        absolute tolerance of velocities [length/time] (default', &
      '                                               the position one per time unit); velocities also get R |v|', &
      '  -ts_monitor, -snes_monitor, -ksp_monitor     progress of steps, Newton, Krylov', &
      '  -snes_rtol R, -snes_max_it N                 Newton tolerance and iterations', &
      '  -snes_type ksponly                           Baraff-Witkin mode: one linearised solve a step', &
      '  -log_view                                    timings at the end', &
      '', &
      'Which integrator for which goal (docs/workprecision.md, docs/convergence.md):', &
      '  fast, moderate accuracy                      -ts_adapt_type basic [-ts_rtol R]: rosw ra34pw2, final', &
      '    (errors 1e-3 .. 1e-5 of the cloth size)    error 0.3-12 R measured (default 2-norm)', &
      '  tight accuracy, a final position error E     -ts_type arkimex -ts_arkimex_type 5', &
      '    (relative to the cloth size)               -ts_arkimex_fully_implicit -ts_adapt_type basic', &
      '                                               -ts_adapt_wnormtype infinity -ts_rtol E  (at most 10 E', &
      '                                               measured; -ts_type bdf -ts_bdf_order 4 or 5 is often', &
      '                                               faster, but its error is not tied to R: check it)', &
      '  speed on large lattices                      -snes_type ksponly -reduced_ksp_rtol 1e-3 with fixed', &
      '                                               steps: the Baraff-Witkin mode, one linear solve a step,', &
      '                                               first order', &
      '  reproducible runs                            fixed steps (no -ts_adapt_type) with -ts_dt DT: the same', &
      '                                               steps whatever the solution; beuler (default) is order 1,', &
      '                                               -ts_type cn order 2, -ts_type rosw order 3 at about the', &
      '                                               cost of cn (fixed-step bdf 3-5: order 2, see docs)', &
      '', &
      'The Newton step (docs/design.md):', &
      '  -nuno_jacobian reduced|full                  reduced (default): only the 3-dof velocity system', &
      '                                               S = a M - C - K/a is assembled and the 6-dof step is', &
      '                                               solved exactly around it; full: the 6-dof Jacobian', &
      '  -reduced_ksp_type, -reduced_pc_type, ...     the inner solver of S (default FGMRES, rtol 1e-6, with', &
      '                                               nuno''s structured multigrid where 3 levels fit, else', &
      '                                               block Jacobi/ILU; CG when S is symmetric and another', &
      '                                               preconditioner is given); -reduced_ksp_view', &
      '  -nuno_mg stencil|petsc                       the inner multigrid: nuno''s (default; single precision,', &
      '                                               stored by stencil offset, no PETSc matrix) or PETSc''s', &
      '                                               PCMG with Galerkin operators and SOR', &
      '  -nuno_mg_cycle kaskade|v                     nuno''s multigrid: kaskade (default: restrict the', &
      '                                               right-hand side, then only upwards) or V-cycles', &
      '  -nuno_mg_sweeps N, -nuno_mg_levels N         symmetric Gauss-Seidel sweeps a smoothing (1), levels', &
      '                                               (0: as many as fit, down to 5 nodes a side)', &
      '  -reduced_dm_mat_type aij|baij|sbaij          storage of S with -reduced_pc_type (default: aij for', &
      '                                               multigrid, baij else); nuno''s multigrid needs none', &
      '  -nuno_pc_lag N                               rebuild the inner preconditioner every N assemblies', &
      '                                               (default 3 with the multigrid, 10 with its cubic', &
      '                                               interpolation, 1 otherwise; and at every output step;', &
      '                                               a failed solve rebuilds it and retries)', &
      '  -nuno_mg_interpolation auto|linear|cubic|coarse_cubic  interpolation of the inner multigrid', &
      '                                               (auto: with bending, whose fourth-order modes', &
      '                                               bilinear transfer does not carry, cubic on every', &
      '                                               level but the finest, whose coarse correction is', &
      '                                               interpolated cubic too; linear without)', &
      '  -nuno_newton_forcing [true|false]            Newton solves each inner system only as far as the', &
      '                                               step needs: its Newton remainder, or half the residual', &
      '                                               at which Newton stops (default true)', &
      '  -nuno_inner_guess auto|none|previous|extrapolate|project  the inner solve''s initial guess:', &
      '                                               the least-squares combination of the last 8 inner', &
      '                                               solves (project; auto: with bending), at a step''s', &
      '                                               first Newton iteration the last two steps'' first', &
      '                                               corrections extrapolated, the last one, or zero', &
      '                                               (auto: without bending)', &
      '  -nuno_newton_start auto|linear|cubic         beuler: Newton starts a step from the last two states', &
      '                                               extrapolated (linear, PETSc''s) or from the polynomial', &
      '                                               through the last four (cubic; auto: for Newton at', &
      '                                               fixed steps, linear with -snes_type ksponly)', &
      '  -snes_lag_jacobian N                         S assembled every N Newton iterations (default 2: the', &
      '                                               second iteration of a step reuses the first one''s S)', &
      '  -ts_theta_initial_guess_extrapolate          beuler starts Newton from x + dt xdot (default true,', &
      '                                               reduced path)', &
      '  -nuno_snes_floor F                           a residual below F times its start or the round-off', &
      '                                               floor that stops decreasing is converged, on both paths', &
      '                                               (default 1e-6; 0: off)', &
      '  -snes_ksp_ew                                 Eisenstat-Walker: its forcing term is the inner rtol', &
      '  -nuno_gauss_newton                           energy bending: Gauss-Newton blocks -k_b J^T J in the', &
      '                                               assembled matrix, S or the 6-dof Jacobian (an inexact', &
      '                                               Newton; with full and -snes_mf_operator: exact operator', &
      '                                               applied matrix-free, Gauss-Newton preconditioner)', &
      '  -nuno_clamp_compression                      drop the indefinite compression term of the springs', &
      '                                               from the assembled matrix (preconditioner use)', &
      '  -nuno_linesearch_fallback bt|l2|none         after a failed Newton solve, the rest of the run takes', &
      '                                               this line search instead of full steps (default bt)', &
      'PETSc''s linear-solver options on the default (reduced) path act on the inner solve of S:', &
      '  -ksp_*, -pc_*, -sub_*, -mg_levels_*, -mg_coarse_*  read as -reduced_ksp_*, -reduced_pc_*, ...:', &
      '                                               -pc_type lu is -reduced_pc_type lu (an exact inner solve),', &
      '                                               -ksp_type preonly -pc_type lu a direct one; -pc_type', &
      '                                               fieldsplit, shell and -dm_mat_type are refused there', &
      'With -nuno_jacobian full (PETSc''s options act on the 6-dof solve as usual):', &
      '  -ksp_type gmres|bcgs|preonly, -pc_type ilu|lu|bjacobi|fieldsplit|gamg', &
      '  -dm_mat_type baij|aij                        Jacobian storage (default baij 6x6; aij for fieldsplit)'
  end subroutine input_usage

  !> Write a few lines that describe the run (call on one rank).
  subroutine input_summary(cfg, unit, ts_dt, ts_max_time)
    type(nuno_config), intent(in) :: cfg
    integer, intent(in) :: unit
    real(rp), intent(in), optional :: ts_dt, ts_max_time   !< -ts_dt, -ts_max_time when given: they win
    character(256) :: terms, cons
    character(len=:), allocatable :: tline
    write(unit, '(a)') 'scene     : '//trim(cfg%scene)
    write(unit, '(a,i0,a,i0,a)') 'lattice   : ', cfg%nx, ' x ', cfg%ny, ' nodes, '// &
      fmt_real(cfg%lx)//' x '//fmt_real(cfg%ly)//' (spacing '//fmt_real(cfg%ax)//' x '// &
      fmt_real(cfg%ay)//'), mass '//fmt_real(cfg%total_mass)//' ('//trim(cfg%mass_distribution)// &
      '), '//trim(cfg%lattice_scaling)//' constants'
    write(unit, '(a)') 'springs   : '//trim(cfg%spring_model)//': E_s = '//fmt_real(cfg%e_s)// &
      ', eta_s = '//fmt_real(cfg%eta_s)//', E_d = '//fmt_real(cfg%e_d)//', eta_d = '//fmt_real(cfg%eta_d)
    select case (cfg%bending_code)
    case (BEND_NONE)
      write(unit, '(a)') 'bending   : none'
    case (BEND_PAPER)
      write(unit, '(a)') 'bending   : paper (report eqs. 2-3): k_b = '//fmt_real(cfg%k_b)//' per radian'
    case (BEND_ENERGY)
      write(unit, '(a)') 'bending   : energy: k_b = '//fmt_real(cfg%k_b)//', eta_b = '//fmt_real(cfg%eta_b)
    end select
    terms = ''
    if (cfg%bending_code /= BEND_NONE) terms = trim(terms)//', bending'
    if (cfg%has_damping .or. (cfg%bending_code == BEND_ENERGY .and. cfg%eta_b > 0.0_rp)) &
      terms = trim(terms)//', damping'
    if (cfg%has_gravity) terms = trim(terms)//', gravity ('//fmt_real(cfg%gravity(1))//', '// &
      fmt_real(cfg%gravity(2))//', '//fmt_real(cfg%gravity(3))//')'
    if (any(cfg%initial_omega /= 0.0_rp)) terms = trim(terms)//', initial spin'
    write(unit, '(a)') 'terms     : springs'//trim(terms)
    select case (cfg%scene_code)
    case (SCENE_LIFT_RELEASE); cons = 'edge i = 0 pinned'
    case (SCENE_WAVE_POINT)
      if (trim(cfg%wave_nodes) == 'edge') then
        cons = 'edge i = 0 prescribed through keyframes'
      else
        cons = 'corner (0,0) prescribed through keyframes'
      end if
    case (SCENE_HANG);         cons = 'corners (0,ny-1) and (nx-1,ny-1) pinned'
    case default;              cons = 'none'
    end select
    if (cfg%release_time < huge(1.0_rp) .and. trim(cons) /= 'none') &
      cons = trim(cons)//', released at t = '//fmt_real(cfg%release_time)
    write(unit, '(a)') 'constraint: '//trim(cons)
    ! The values the run uses: an option over the namelist says so.
    if (present(ts_max_time)) then
      tline = 'time      : t_end = '//fmt_real(ts_max_time)//' (-ts_max_time; namelist '//fmt_real(cfg%t_end)//')'
    else
      tline = 'time      : t_end = '//fmt_real(cfg%t_end)
    end if
    if (present(ts_dt)) then
      tline = tline//', dt = '//fmt_real(ts_dt)//' (-ts_dt; namelist '//fmt_real(cfg%dt)//')'
    else
      tline = tline//', dt = '//fmt_real(cfg%dt)
    end if
    write(unit, '(a)') tline
    if (cfg%write_velocity) then
      write(unit, '(a)') 'output    : '//trim(cfg%output_file)//' every '//fmt_real(cfg%output_interval)// &
        ' (with velocity)'
    else
      write(unit, '(a)') 'output    : '//trim(cfg%output_file)//' every '//fmt_real(cfg%output_interval)
    end if
  end subroutine input_summary

  ! ==========================================================================
  ! Small helpers
  ! ==========================================================================

  !> Shortest decimal that reads back as x (fixed notation for moderate values).
  function fmt_real(x) result(s)
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
  end function fmt_real

  pure function lower(s) result(r)
    character(*), intent(in) :: s
    character(len(s)) :: r
    integer :: i
    r = s
    do i = 1, len(s)
      if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') r(i:i) = achar(iachar(s(i:i)) + 32)
    end do
  end function lower

end module input
