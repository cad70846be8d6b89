! SPDX-License-Identifier: BSD-2-Clause
!> -identify_check_gradient, -control_check_gradient: the adjoint gradient
!> of an identification or a control against central differences of its
!> objective (docs/identification.md).
module identify_check
#include "petsc/finclude/petscsys.h"
  use petscsys
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use config, only: fit_kind_names
  use identify_params, only: MODE_CONTROL, XYZ
  use identify_adjoint, only: ident_core_t, forward, objective_gradient, failed_run
  implicit none
  private
  public :: check_gradient

contains

  !> -identify_check_gradient (-control_check_gradient): the adjoint
  !> gradient at the initial guess against central differences of the
  !> objective (step fd_step; second order for identification, fourth
  !> order for control), one line per direction on rank 0, and the
  !> measured costs. Identification: each ln p. Control: each optimised
  !> component of each keyframe position m = 2..nk (moving keyframe m alone
  !> changes the steps into m and out of it: dJ/dkoff(c, m) = dJ/dd_m -
  !> dJ/dd_(m+1)).
  subroutine check_gradient(id, ierr, errmsg)
    class(ident_core_t), intent(inout) :: id
    PetscErrorCode, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    real(rp) :: f, fp, fm, f2p, f2m, g(id%par%np), dir(id%par%np), gd, fd, tf, wall0
    integer :: k, q
    character(len=32) :: label

    wall0 = MPI_Wtime()
    call forward(id, id%par%theta0, f, ierr)
    if (ierr /= 0) return
    tf = MPI_Wtime() - wall0
    wall0 = MPI_Wtime()
    call objective_gradient(id, id%par%theta0, f, g, ierr)
    if (ierr /= 0) return
    if (failed_run(id, id%par%theta0, errmsg, ierr)) return
    if (id%app%rank == 0) then
      write(output_unit, '(a,es24.16)') trim(id%par%tag)//': objective ', f
      write(output_unit, '(a,es12.4,a,es12.4,a,f7.3,2(a,es12.4),a,i0,a)') trim(id%par%tag)//': cost forward_s ', tf, &
        ' gradient_s ', MPI_Wtime() - wall0, ' ratio ', (MPI_Wtime() - wall0) / tf, &
        ' trajectory_memory_bytes ', id%run%traj_bytes, ' trajectory_file_bytes ', id%run%traj_disk_bytes, ' steps ', id%run%nsteps, ' (gradient = forward + adjoint)'
    end if
    do k = 1, id%par%np
      dir = 0.0_rp
      dir(k) = 1.0_rp
      if (id%par%mode == MODE_CONTROL) then
        do q = 1, id%par%np
          if (id%par%km(q) == id%par%km(k) + 1 .and. id%par%kc(q) == id%par%kc(k)) dir(q) = -1.0_rp
        end do
        write(label, '(a,i0,a)') 'keyframe_d'//XYZ(id%par%kc(k))//'(', id%par%km(k), ')'
      else
        label = fit_kind_names(id%par%code(k))
      end if
      gd = dot_product(g, dir)
      call forward(id, id%par%theta0 + id%par%fd_step * dir, fp, ierr)
      if (ierr /= 0) return
      call forward(id, id%par%theta0 - id%par%fd_step * dir, fm, ierr)
      if (ierr /= 0) return
      if (failed_run(id, id%par%theta0, errmsg, ierr)) return
      fd = (fp - fm) / (2.0_rp * id%par%fd_step)
      if (id%par%mode == MODE_CONTROL) then
        ! The fourth-order central difference: in-plane steps stretch
        ! links, and the second-order one's truncation error (measured
        ! 1e-4 relative at a step of 1e-5 lx, 1e-6 at 1e-6 lx, where
        ! round-off begins) would hide an error of the adjoint.
        call forward(id, id%par%theta0 + 2.0_rp * id%par%fd_step * dir, f2p, ierr)
        if (ierr /= 0) return
        call forward(id, id%par%theta0 - 2.0_rp * id%par%fd_step * dir, f2m, ierr)
        if (ierr /= 0) return
        if (failed_run(id, id%par%theta0, errmsg, ierr)) return
        fd = (8.0_rp * (fp - fm) - (f2p - f2m)) / (12.0_rp * id%par%fd_step)
      end if
      if (id%app%rank == 0) write(output_unit, '(a,a,a,es24.16,a,es24.16,a,es10.3)') trim(id%par%tag)//': gradient ', &
        trim(label), ' adjoint ', gd, ' fd ', fd, ' relerr ', abs(gd - fd) / max(abs(fd), tiny(1.0_rp))
    end do
    if (id%app%rank == 0) flush(output_unit)
  end subroutine check_gradient

end module identify_check
