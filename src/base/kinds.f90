! SPDX-License-Identifier: BSD-2-Clause
!> Real kind of the whole program: double precision, the same as PETSc's
!> PetscReal and PetscScalar in the build nuno needs (real scalars, double
!> precision). Not checked at run time: PETSc's arrays and reals are passed
!> to real(rp) dummy arguments with explicit interfaces, so against a PETSc
!> of another precision, or of complex scalars, nuno does not compile.
module kinds
  use, intrinsic :: iso_fortran_env, only: real64, int64
  implicit none
  private
  public :: rp, i8
  integer, parameter :: rp = real64
  integer, parameter :: i8 = int64
end module kinds
