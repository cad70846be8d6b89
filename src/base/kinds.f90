! SPDX-License-Identifier: BSD-2-Clause
!> Real kind of the whole program: double precision, the same as PETSc's
!> PetscReal in the Debian build (checked at start-up by the solver).
module kinds
  use, intrinsic :: iso_fortran_env, only: real64, int64
  implicit none
  private
  public :: rp, i8
  integer, parameter :: rp = real64
  integer, parameter :: i8 = int64
end module kinds
