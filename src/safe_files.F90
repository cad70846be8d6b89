!> Thin Fortran wrappers of src/nuno_files.c (POSIX: flock, stat, rename,
!> with strerror causes) for the safe output files of module output. Local:
!> each call acts on the calling rank only; the caller makes it collective.
module safe_files
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char, c_double
  implicit none
  private
  public :: lock_acquire, lock_release, same_file, file_exists, rename_file, free_bytes

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
  end interface

contains

  !> Exclusive lock on file `path` for the life of this process (or until
  !> lock_release). code: 0 taken (fd set), 1 held by another process, 2
  !> other error; detail: the holder ('pid N on host') or the cause.
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
  end subroutine lock_acquire

  !> Drop a lock taken by lock_acquire (unlinks the lock file); fd < 0: nothing.
  subroutine lock_release(path, fd)
    character(*), intent(in) :: path
    integer, intent(inout) :: fd
    if (fd >= 0) call c_lock_release(path//c_null_char, int(fd, c_int))
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
