! SPDX-License-Identifier: BSD-2-Clause
!> Thin Fortran wrappers of src/output/nuno_files.c (POSIX: flock, stat, rename,
!> mkstemp, mkdtemp, with strerror causes) for the safe output files of
!> module output, and the rules for the names nuno writes (input/README.md,
!> "Output files"): no control character, not too long for MPI-IO, never an
!> input file, never a symbolic link, never a file that is not nuno's own.
!> Local: each call acts on the calling rank only (the caller makes it
!> collective), except check_output_name.
module safe_files
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char, c_double
  use hdf5
  use mpi
  use strings, only: itoa
  implicit none
  private
  public :: lock_acquire, lock_release, same_file, file_exists, rename_file, free_bytes
  public :: path_kind, kind_none, kind_file, kind_link, kind_dir, kind_other, kind_unknown
  public :: sidecar_path, obstacles_sidecar_path, remove_file, is_nuno_output, is_nuno_sidecar, check_output_name, output_name_max
  public :: tmp_open, tmp_write, tmp_commit, make_scratch_dir, remove_scratch
  public :: cleanup_add, cleanup_drop, cleanup_run, cleanup_file, cleanup_dir, cleanup_lock

  !> What a name is (path_kind; a symbolic link is not followed).
  integer, parameter :: kind_none = 0, kind_file = 1, kind_link = 2, kind_dir = 3, kind_other = 4, kind_unknown = 5
  !> What cleanup_run does with a registered name: remove a file, a scratch directory, a lock.
  integer, parameter :: cleanup_file = 1, cleanup_dir = 2, cleanup_lock = 3
  !> The longest output file name nuno accepts [characters, as written].
  !> The run opens OUTPUT.partial, and Open MPI 4.1's MPI-IO (ompio and its
  !> shared file pointer components) builds names of the name it is given
  !> plus suffixes of its own (`_cid-N-M.sm`) in 256-byte buffers: an
  !> output_file of 237 characters aborted every rank (SIGABRT, "buffer
  !> overflow detected"), one of 233 made MPI_File_open fail (measured with
  !> Open MPI 4.1.4, HDF5 1.10.8). 200 leaves room; a longer path works from
  !> its directory (cd there, or a symbolic link to the directory).
  integer, parameter :: output_name_max = 200

  integer, parameter :: cmsg_len = 256

  interface
    function c_lock_acquire(path, fd, msg, msglen) bind(C, name='nuno_lock_acquire') result(code)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), intent(out) :: fd
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: msglen
      integer(c_int) :: code
    end function c_lock_acquire
    subroutine c_lock_release(path, fd) bind(C, name='nuno_lock_release')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), value :: fd
    end subroutine c_lock_release
    function c_same_file(a, b) bind(C, name='nuno_same_file') result(same)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: a(*), b(*)
      integer(c_int) :: same
    end function c_same_file
    function c_exists(path) bind(C, name='nuno_exists') result(yes)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int) :: yes
    end function c_exists
    function c_rename(from, to, msg, msglen) bind(C, name='nuno_rename') result(code)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: from(*), to(*)
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: msglen
      integer(c_int) :: code
    end function c_rename
    function c_free_bytes(path) bind(C, name='nuno_free_bytes') result(bytes)
      import :: c_char, c_double
      character(kind=c_char), intent(in) :: path(*)
      real(c_double) :: bytes
    end function c_free_bytes
    function c_path_kind(path, msg, msglen) bind(C, name='nuno_path_kind') result(k)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: msglen
      integer(c_int) :: k
    end function c_path_kind
    function c_remove_file(path, msg, msglen) bind(C, name='nuno_remove_file') result(code)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: msglen
      integer(c_int) :: code
    end function c_remove_file
    function c_tmp_open(path, tmp, tmplen, fd, msg, msglen) bind(C, name='nuno_tmp_open') result(code)
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      character(kind=c_char), intent(out) :: tmp(*), msg(*)
      integer(c_int), value :: tmplen, msglen
      integer(c_int), intent(out) :: fd
      integer(c_int) :: code
    end function c_tmp_open
    function c_tmp_write(fd, buf, n) bind(C, name='nuno_tmp_write') result(code)
      import :: c_int, c_char
      integer(c_int), value :: fd, n
      character(kind=c_char), intent(in) :: buf(*)
      integer(c_int) :: code
    end function c_tmp_write
    function c_tmp_commit(fd, tmp, path, ok, msg, msglen) bind(C, name='nuno_tmp_commit') result(code)
      import :: c_int, c_char
      integer(c_int), value :: fd, ok, msglen
      character(kind=c_char), intent(in) :: tmp(*), path(*)
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int) :: code
    end function c_tmp_commit
    function c_mkdtemp(templ, msg, msglen) bind(C, name='nuno_mkdtemp') result(code)
      import :: c_int, c_char
      character(kind=c_char), intent(inout) :: templ(*)
      character(kind=c_char), intent(out) :: msg(*)
      integer(c_int), value :: msglen
      integer(c_int) :: code
    end function c_mkdtemp
    subroutine c_remove_scratch(dir) bind(C, name='nuno_remove_scratch')
      import :: c_char
      character(kind=c_char), intent(in) :: dir(*)
    end subroutine c_remove_scratch
    subroutine c_cleanup_add(path, kind, fd) bind(C, name='nuno_cleanup_add')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), value :: kind, fd
    end subroutine c_cleanup_add
    subroutine c_cleanup_drop(path) bind(C, name='nuno_cleanup_drop')
      import :: c_char
      character(kind=c_char), intent(in) :: path(*)
    end subroutine c_cleanup_drop
    subroutine c_cleanup_run() bind(C, name='nuno_cleanup_run')
    end subroutine c_cleanup_run
  end interface

contains

  !> Exclusive lock on file `path` for the life of this process (or until
  !> lock_release). code: 0 taken (fd set), 1 held by another process, 2
  !> other error, 3 the name is taken by what is not a lock file of nuno (a
  !> symbolic link, a user's file); detail: the holder ('pid N on host') or
  !> the cause. The lock file is made exclusively, never through a link.
  subroutine lock_acquire(path, fd, code, detail)
    character(*), intent(in) :: path
    integer, intent(out) :: fd, code
    character(*), intent(out) :: detail
    character(kind=c_char, len=cmsg_len) :: buf
    integer(c_int) :: cfd
    cfd = -1
    buf = ''
    code = c_lock_acquire(path//c_null_char, cfd, buf, int(cmsg_len, c_int))
    fd = cfd
    detail = c_text(buf)
    if (code == 0) call cleanup_add(path, cleanup_lock, fd)
  end subroutine lock_acquire

  !> Drop a lock taken by lock_acquire (unlinks the lock file); fd < 0: nothing.
  subroutine lock_release(path, fd)
    character(*), intent(in) :: path
    integer, intent(inout) :: fd
    if (fd >= 0) call c_lock_release(path//c_null_char, int(fd, c_int))
    if (fd >= 0) call cleanup_drop(path)
    fd = -1
  end subroutine lock_release

  !> Whether a and b are the same file (same inode, or the same resolved path when b does not exist).
  logical function same_file(a, b)
    character(*), intent(in) :: a, b
    same_file = c_same_file(a//c_null_char, b//c_null_char) /= 0
  end function same_file

  logical function file_exists(path)
    character(*), intent(in) :: path
    file_exists = c_exists(path//c_null_char) /= 0
  end function file_exists

  !> rename(2): atomic within a file system; ok = .false. with the cause in detail.
  subroutine rename_file(from, to, ok, detail)
    character(*), intent(in) :: from, to
    logical, intent(out) :: ok
    character(*), intent(out) :: detail
    character(kind=c_char, len=cmsg_len) :: buf
    buf = ''
    ok = c_rename(from//c_null_char, to//c_null_char, buf, int(cmsg_len, c_int)) == 0
    detail = c_text(buf)
  end subroutine rename_file

  !> Bytes free on the file system that holds path (-1: unknown).
  real(c_double) function free_bytes(path)
    character(*), intent(in) :: path
    free_bytes = c_free_bytes(path//c_null_char)
  end function free_bytes

  !> What the name is, without following a symbolic link (kind_*);
  !> detail: the cause for kind_unknown.
  integer function path_kind(path, detail)
    character(*), intent(in) :: path
    character(*), intent(out) :: detail
    character(kind=c_char, len=cmsg_len) :: buf
    buf = ''
    path_kind = c_path_kind(path//c_null_char, buf, int(cmsg_len, c_int))
    detail = c_text(buf)
  end function path_kind

  !> Remove path if it is a regular file (never a link, never a directory);
  !> ok = .true. when it is gone.
  subroutine remove_file(path, ok, detail)
    character(*), intent(in) :: path
    logical, intent(out) :: ok
    character(*), intent(out) :: detail
    character(kind=c_char, len=cmsg_len) :: buf
    buf = ''
    ok = c_remove_file(path//c_null_char, buf, int(cmsg_len, c_int)) == 0
    detail = c_text(buf)
  end subroutine remove_file

  !> Whether the regular file path is an output file of nuno: an HDF5 file
  !> with the root attributes program_version, status and nx that every
  !> nuno file has from its creation on (module output). Serial (this rank
  !> only, HDF5's default driver); HDF5's error printing stays off.
  logical function is_nuno_output(path)
    character(*), intent(in) :: path
    integer(hid_t) :: file
    integer :: h, e
    logical :: yes
    is_nuno_output = .false.
    call h5open_f(h)
    call h5eset_auto_f(0, h)
    call h5fopen_f(path, H5F_ACC_RDONLY_F, file, e)
    if (e < 0) return
    is_nuno_output = .true.
    call h5aexists_f(file, 'program_version', yes, e)
    is_nuno_output = is_nuno_output .and. e >= 0 .and. yes
    call h5aexists_f(file, 'status', yes, e)
    is_nuno_output = is_nuno_output .and. e >= 0 .and. yes
    call h5aexists_f(file, 'nx', yes, e)
    is_nuno_output = is_nuno_output .and. e >= 0 .and. yes
    call h5fclose_f(file, e)
  end function is_nuno_output

  !> Whether the regular file path is an XDMF sidecar as nuno writes them
  !> (module output, write_xdmf: its first two lines).
  logical function is_nuno_sidecar(path)
    character(*), intent(in) :: path
    character(len=*), parameter :: head = '<?xml version="1.0" ?>'//achar(10)//'<Xdmf Version="3.0">'
    character(len=len(head)) :: buf
    integer :: u, ios
    is_nuno_sidecar = .false.
    open(newunit=u, file=path, access='stream', form='unformatted', action='read', status='old', iostat=ios)
    if (ios /= 0) return
    read(u, iostat=ios) buf
    close(u)
    is_nuno_sidecar = ios == 0 .and. buf == head
  end function is_nuno_sidecar

  !> A new file beside path made exclusively (mkstemp), to be written by
  !> tmp_write and put in place by tmp_commit: a side file rewritten whole
  !> (the XDMF sidecar) is never written through a symbolic link.
  subroutine tmp_open(path, tmp, fd, ok, detail)
    character(*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: tmp
    integer, intent(out) :: fd
    logical, intent(out) :: ok
    character(*), intent(out) :: detail
    character(kind=c_char, len=cmsg_len) :: buf
    character(kind=c_char, len=len(path) + 16) :: name
    integer(c_int) :: cfd
    buf = ''
    name = ''
    cfd = -1
    ok = c_tmp_open(path//c_null_char, name, int(len(name), c_int), cfd, buf, int(cmsg_len, c_int)) == 0
    fd = cfd
    tmp = c_text(name)
    detail = c_text(buf)
  end subroutine tmp_open

  !> Append text (as it is: newlines included by the caller) to the file of
  !> tmp_open; ok stays .false. after a failed write.
  subroutine tmp_write(fd, text, ok)
    integer, intent(in) :: fd
    character(*), intent(in) :: text
    logical, intent(inout) :: ok
    if (.not. ok) return
    ok = c_tmp_write(int(fd, c_int), text, int(len(text), c_int)) == 0
  end subroutine tmp_write

  !> Close the file of tmp_open and rename it onto path (ok on entry), or remove it.
  subroutine tmp_commit(fd, tmp, path, ok, detail)
    integer, intent(in) :: fd
    character(*), intent(in) :: tmp, path
    logical, intent(inout) :: ok
    character(*), intent(out) :: detail
    character(kind=c_char, len=cmsg_len) :: buf
    buf = ''
    ok = c_tmp_commit(int(fd, c_int), tmp//c_null_char, path//c_null_char, merge(1_c_int, 0_c_int, ok), buf, &
                      int(cmsg_len, c_int)) == 0
    detail = c_text(buf)
  end subroutine tmp_commit

  !> A new private directory named prefix//'.XXXXXX' (mkdtemp: the X made
  !> unique, mode 0700); dir: its name. Registered for cleanup_run.
  subroutine make_scratch_dir(prefix, dir, ok, detail)
    character(*), intent(in) :: prefix
    character(len=:), allocatable, intent(out) :: dir
    logical, intent(out) :: ok
    character(*), intent(out) :: detail
    character(kind=c_char, len=len(prefix) + 8) :: templ
    character(kind=c_char, len=cmsg_len) :: buf
    buf = ''
    templ = prefix//'.XXXXXX'//c_null_char
    ok = c_mkdtemp(templ, buf, int(cmsg_len, c_int)) == 0
    dir = c_text(templ)
    detail = c_text(buf)
    if (ok) call cleanup_add(dir, cleanup_dir)
  end subroutine make_scratch_dir

  !> Remove a directory made by make_scratch_dir and all in it (links are
  !> removed, never followed) and drop it from the cleanup registry.
  subroutine remove_scratch(dir)
    character(*), intent(in) :: dir
    call c_remove_scratch(dir//c_null_char)
    call cleanup_drop(dir)
  end subroutine remove_scratch

  !> Register a name this run made, to be removed by cleanup_run if the run
  !> ends in an error before it became a result (what: cleanup_*; fd: the
  !> lock's descriptor).
  subroutine cleanup_add(path, what, fd)
    character(*), intent(in) :: path
    integer, intent(in) :: what
    integer, intent(in), optional :: fd
    integer(c_int) :: cfd
    cfd = -1
    if (present(fd)) cfd = fd
    call c_cleanup_add(path//c_null_char, int(what, c_int), cfd)
  end subroutine cleanup_add

  !> The name is a result now (or removed already): cleanup_run leaves it.
  subroutine cleanup_drop(path)
    character(*), intent(in) :: path
    call c_cleanup_drop(path//c_null_char)
  end subroutine cleanup_drop

  !> At an error exit: remove what this rank registered (a failed start leaves nothing it did not find).
  subroutine cleanup_run()
    call c_cleanup_run()
  end subroutine cleanup_run

  !> One line when `name` (the value of the input's `key`) cannot be the
  !> name of a file nuno writes, '' when it can: a control character (a
  !> NUL cuts the name where the C library reads it), more than
  !> output_name_max characters, or (protect) the name of an input file,
  !> also through the names derived from it (derived). Rank 0 looks, every
  !> rank gets the answer. Collective.
  subroutine check_output_name(comm, key, name, full, protect, derived, ierr, errmsg)
    integer, intent(in) :: comm
    character(*), intent(in) :: key          ! as the line names it: "&output: output_file"
    character(*), intent(in) :: name         ! trimmed
    logical, intent(in) :: full              ! the buffer it was read into was full: maybe truncated
    character(*), intent(in) :: protect(:)   ! input files ('' entries ignored)
    character(*), intent(in) :: derived(:)   ! the other names written with it (side files)
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: rank, mpierr, k, j, c
    character(len=12) :: num
    character(len=:), allocatable :: cand

    ierr = 0
    errmsg = ''
    call MPI_Comm_rank(comm, rank, mpierr)
    if (rank == 0) then
      do k = 1, len(name)
        c = iachar(name(k:k))
        if (c < 32 .or. c == 127) then
          ierr = 1
          write(num, '(i0)') c
          errmsg = 'input: '//key//" = '"//printable(name)//"' has a control character (byte "//trim(num)// &
                   ' at position '//trim(itoa(k))//'): a file name must not have one'
          exit
        end if
      end do
      if (ierr == 0 .and. (full .or. len(name) > output_name_max)) then
        ierr = 1
        errmsg = 'input: '//key//" = '"//name(1:min(len(name), 60))//"...' is "//trim(itoa(len(name)))// &
                 merge(' or more', '        ', full)
        errmsg = trim(errmsg)//' characters long; at most '//trim(itoa(output_name_max))// &
                 ' (Open MPI''s MPI-IO fails on longer names): write it from the directory it is in'
      end if
      do k = 1, size(protect)
        if (ierr /= 0) exit
        if (len_trim(protect(k)) == 0) cycle
        do j = 0, size(derived)
          cand = name
          if (j > 0) cand = trim(derived(j))
          if (len(cand) == 0) cycle
          if (same_file(trim(protect(k)), cand)) then
            ierr = 1
            errmsg = 'input: '//key//" = '"//name//"' would overwrite the input file "//trim(protect(k))// &
                     ': choose another name'
            exit
          end if
        end do
      end do
    end if
    call MPI_Bcast(ierr, 1, MPI_INTEGER, 0, comm, mpierr)
    call MPI_Bcast(errmsg, len(errmsg), MPI_CHARACTER, 0, comm, mpierr)
  contains
    !> The name with each control character written as ^@, ^A, ... (one line).
    function printable(s) result(r)
      character(*), intent(in) :: s
      character(len=:), allocatable :: r
      integer :: i
      r = ''
      do i = 1, min(len(s), 120)
        select case (iachar(s(i:i)))
        case (0:31)
          r = r//'^'//achar(iachar(s(i:i)) + 64)
        case (127)
          r = r//'^?'
        case default
          r = r//s(i:i)
        end select
      end do
    end function printable
  end subroutine check_output_name

  !> The XDMF sidecar of an output file: run.h5 -> run.xdmf, other -> other.xdmf
  !> (module output's rule). .xdmf, not .xmf: VTK's readers (pyvista.read,
  !> vtkXdmfReader) pick a reader by this extension and know only .xdmf;
  !> ParaView opens both.
  function sidecar_path(filename) result(xmf)
    character(*), intent(in) :: filename
    character(len=:), allocatable :: xmf
    integer :: n
    n = len(filename)
    if (n > 3) then
      if (filename(n - 2:n) == '.h5') then
        xmf = filename(1:n - 3)//'.xdmf'
        return
      end if
    end if
    xmf = filename//'.xdmf'
  end function sidecar_path

  !> The XDMF sidecar of the obstacles of an output file (a scene with
  !> contact): run.h5 -> run-obstacles.xdmf, other -> other-obstacles.xdmf.
  !> Its own file, not a grid of run.xdmf: pyvista.read("run.xdmf") stays
  !> one StructuredGrid (postprocess/README.md, "ParaView").
  function obstacles_sidecar_path(filename) result(xmf)
    character(*), intent(in) :: filename
    character(len=:), allocatable :: xmf
    xmf = sidecar_path(filename)
    xmf = xmf(1:len(xmf) - 5)//'-obstacles.xdmf'
  end function obstacles_sidecar_path

  !> The text of a NUL-terminated C buffer.
  function c_text(buf) result(s)
    character(kind=c_char, len=*), intent(in) :: buf
    character(len=:), allocatable :: s
    integer :: n
    n = index(buf, c_null_char) - 1
    if (n < 0) n = len_trim(buf)
    s = buf(1:n)
  end function c_text

end module safe_files
