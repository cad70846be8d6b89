! SPDX-License-Identifier: BSD-2-Clause
!> Work arrays kept from call to call (the house rule: no allocation in the
!> time loop): `grow` reallocates an array only when it is shorter than asked,
!> with a quarter more room so that a slowly growing size settles, and counts
!> each reallocation in the caller's counter (self-contact reports the sum);
!> the contents are not kept. `push` appends to a list whose first n
!> entries are kept (doubling when full). Used by self-contact's broad phase,
!> exchange and process model.
module work_arrays
  use, intrinsic :: iso_fortran_env, only: int64
  use kinds, only: rp
  implicit none
  private
  public :: grow, grow_from0, push

  !> grow(a, n..., regrown): a at least n long (the last dimension; the others as given).
  interface grow
    module procedure grow_int, grow_int64, grow_real, grow_int2, grow_real2, grow_real3
  end interface grow

contains

  pure integer function roomy(n)
    integer, intent(in) :: n
    roomy = max(n + n / 4, 1)
  end function roomy

  pure subroutine grow_int(a, n, regrown)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (size(a) >= n) return
      deallocate(a)
    end if
    allocate(a(roomy(n)))
    regrown = regrown + 1
  end subroutine grow_int

  pure subroutine grow_int64(a, n, regrown)
    integer(int64), allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (size(a) >= n) return
      deallocate(a)
    end if
    allocate(a(roomy(n)))
    regrown = regrown + 1
  end subroutine grow_int64

  pure subroutine grow_real(a, n, regrown)
    real(rp), allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (size(a) >= n) return
      deallocate(a)
    end if
    allocate(a(roomy(n)))
    regrown = regrown + 1
  end subroutine grow_real

  !> a(m, n+).
  pure subroutine grow_int2(a, m, n, regrown)
    integer, allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: m, n
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (size(a, 1) == m .and. size(a, 2) >= n) return
      deallocate(a)
    end if
    allocate(a(m, roomy(n)))
    regrown = regrown + 1
  end subroutine grow_int2

  !> a(m, n+).
  pure subroutine grow_real2(a, m, n, regrown)
    real(rp), allocatable, intent(inout) :: a(:, :)
    integer, intent(in) :: m, n
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (size(a, 1) == m .and. size(a, 2) >= n) return
      deallocate(a)
    end if
    allocate(a(m, roomy(n)))
    regrown = regrown + 1
  end subroutine grow_real2

  !> a(m, 0:nx-1, n+): values of the nodes of lattice rows.
  pure subroutine grow_real3(a, m, nx, n, regrown)
    real(rp), allocatable, intent(inout) :: a(:, :, :)
    integer, intent(in) :: m, nx, n
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (size(a, 1) == m .and. size(a, 2) == nx .and. size(a, 3) >= n) return
      deallocate(a)
    end if
    allocate(a(m, 0:nx - 1, roomy(n)))
    regrown = regrown + 1
  end subroutine grow_real3

  !> a(0:top+) with the lower bound 0.
  pure subroutine grow_from0(a, top, regrown)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: top
    integer, intent(inout) :: regrown
    if (allocated(a)) then
      if (ubound(a, 1) >= top) return
      deallocate(a)
    end if
    allocate(a(0:roomy(top + 1) - 1))
    regrown = regrown + 1
  end subroutine grow_from0

  !> a(n + 1) = v, a(1:n) kept, a grown (doubled) where too short.
  pure subroutine push(a, n, v, regrown)
    integer, allocatable, intent(inout) :: a(:)
    integer, intent(in) :: n, v
    integer, intent(inout) :: regrown
    integer, allocatable :: b(:)
    if (.not. allocated(a)) then
      allocate(a(max(16, n + 1)))
      regrown = regrown + 1
    else if (size(a) <= n) then
      allocate(b(2 * (n + 1)))
      b(1:n) = a(1:n)
      call move_alloc(b, a)
      regrown = regrown + 1
    end if
    a(n + 1) = v
  end subroutine push

end module work_arrays
