! SPDX-License-Identifier: BSD-2-Clause
!> Module reduced: the elimination. The outer KSP's PCSHELL solves the 6-dof
!> Newton system through the 3-dof S system and the back-substitution; the
!> TS's MATSHELL is the exact 6-dof product.
!>
!> With shift a, the 6-dof Jacobian (rows divided by the mass, as in module
!> cloth_model) is [[a I, -I], [-K/m, a I - C/m]] on free nodes and a I on
!> constrained ones (K = df/dx, C = df/dv). For a right-hand side
!> b = (b_x, b_v) the x-rows give dx = (dv + b_x)/a (free) or b_x/a
!> (constrained), and the v-rows, multiplied by the mass, give
!>   S dv = m b_v + K b_x / a + C z,   S = a M - C - K/a,
!> where z holds dv = b_v / a on constrained nodes and 0 elsewhere; S has
!> the row a m I on constrained nodes and no constrained columns. S is
!> symmetric whenever K and C are. K b_x/a + C z is computed element by
!> element from the same Jacobian blocks as S (no K matrix is stored).
!>
!> PETSc structure: the TS's Jacobian is a MATSHELL (the exact 6-dof action,
!> matrix-free, for outer Krylov methods and Eisenstat-Walker); the outer
!> KSP is preonly with a PCSHELL that does the elimination; the inner KSP
!> (options prefix -reduced_) solves S dv = rhs. Its convergence is the
!> true residual of the 6-dof system's v-rows, times the mass.
submodule (reduced) reduced_elim
#include "petsc/finclude/petscsnes.h"
#include "petsc/finclude/petscdmda.h"
  use ghosted_state, only: ghosted_get, ghosted_restore
  implicit none

contains

  !> g = -(K w_x + C w_v) on the owned rows, at the state of the last
  !> assembly, from the element blocks: one pass over the elements with
  !> the assembly's vector kernels, S not written (reduced_assembly's
  !> kc_products; kd comes out as the assembly left it). Through the element
  !> buffer one block at a time, a product with the 6-dof Jacobian took 3
  !> assemblies' time, and every iteration of a backtracking line search
  !> one (its slope): -snes_linesearch_type bt ran 2.4x slower.
  subroutine element_products(red, w)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: w(0:, 0:, red%lat%gys:)
    call kc_products(red%lat, red%nodal, red%el%ujac, red%el%fixedg, red%el%damping, red%el%clamp, red%el%gauss_newton, w, &
                     red%el%lb, red%el%g, red%el%kd)
  end subroutine element_products

  !> g -= K_ab w_x,b + C_ab w_v,b of the process models' pair blocks
  !> (self-contact: nodes b anywhere, constrained ones too), where some
  !> rank has any; w (0:5, 0:nx-1, gys:gye) ghosted. Collective.
  subroutine pair_products(red, w, ierr)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: w(0:, 0:, red%lat%gys:)
    PetscErrorCode, intent(out) :: ierr
    integer :: err
    MPI_Comm :: comm
    ierr = 0
    if (.not. associated(red%pms)) return
    if (.not. pm_list_pairs_on(red%pms)) return
    PetscCall(PetscObjectGetComm(red%da3, comm, ierr))
    call pm_list_pair_rhs(red%pms, red%lat, comm, w(:, :, red%lat%ys:red%lat%ye), red%el%g, err)
    if (err /= 0) then
      ierr = PETSC_ERR_PLIB
      SETERRQ(comm, ierr, 'nuno: the pair blocks'' rows could not be gathered for the reduced products (their plan changed since the Jacobian)')
    end if
  end subroutine pair_products

  !> The right-hand side of S dv = rhs for the 6-dof right-hand side b
  !> (global, dof 6): rhs = m b_v + K b_x/a + C z (see the header above).
  !> Collective (one halo exchange of b).
  subroutine reduced_rhs(red, b, rhs, ierr)
    type(reduced_t), intent(inout) :: red
    type(tVec) :: b, rhs
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: bloc
    PetscScalar, pointer :: bl(:, :, :), r(:, :, :)
    integer :: i, j
    real(rp) :: ainv
    logical :: any_w

    ainv = 1.0_rp / red%a
    any_w = .false.
    PetscCall(ghosted_get(red%da6, b, bloc, bl, ierr))
    do j = red%lat%gys, red%lat%gye
      do i = 0, red%lat%nx - 1
        ! After a Newton update the x-rows are solved exactly: what is left
        ! of b_x is the round-off of xdot - v (a few eps (a |x| + |v|)), and
        ! its products, of that size too, would cost a pass over the elements
        ! (a lagged S: -snes_lag_jacobian).
        if (all(abs(bl(0:2, i, j)) <= 8.0_rp * epsilon(1.0_rp) * &
                (red%a * maxval(abs(red%el%ujac(0:2, i, j))) + maxval(abs(red%el%ujac(3:5, i, j)))))) then
          red%el%w(0:2, i, j) = 0.0_rp
        else
          red%el%w(0:2, i, j) = ainv * bl(0:2, i, j)
        end if
        if (red%el%fixedg(i, j)) then
          red%el%w(3:5, i, j) = ainv * bl(3:5, i, j)
        else
          red%el%w(3:5, i, j) = 0.0_rp
        end if
        any_w = any_w .or. any(red%el%w(:, i, j) /= 0.0_rp)
      end do
    end do
    ! b_x = 0 and no constrained dv: the products vanish. b = +-F(u) at the
    ! assembled state (a Newton step): formed during the assembly.
    ! Anything else: one pass over the elements.
    if (.not. any_w) then
      red%el%g = 0.0_rp
    else if (red%el%have_pred .and. same(red%el%w, red%el%wpred, 1.0_rp)) then
      red%el%g = red%el%gpred
    else if (red%el%have_pred .and. same(red%el%w, red%el%wpred, -1.0_rp)) then
      red%el%g = -red%el%gpred
    else
      call element_products(red, red%el%w)
    end if
    PetscCall(pair_products(red, red%el%w, ierr))
    ! A constrained node's row takes no element products (its row of S is
    ! a m I): m b_v - 0 there, which is m b_v to the bit.
    PetscCall(DMDAVecGetArrayF90(red%da3, rhs, r, ierr))
    do j = red%lat%ys, red%lat%ye
      do i = 0, red%lat%nx - 1
        r(0:2, i, j) = red%lat%mass(i, j) * bl(3:5, i, j) - merge(0.0_rp, red%el%g(:, i, j), red%el%fixedg(i, j))
      end do
    end do
    PetscCall(DMDAVecRestoreArrayF90(red%da3, rhs, r, ierr))
    PetscCall(ghosted_restore(red%da6, bloc, bl, ierr))
  end subroutine reduced_rhs

  !> x = sgn y up to round-off (both come from the same expressions); no
  !> temporary arrays (called once per Newton iteration).
  pure logical function same(x, y, sgn)
    real(rp), intent(in) :: x(:, :, :), y(:, :, :)
    real(rp), intent(in) :: sgn
    real(rp) :: dmax, ymax
    integer :: i, j, k
    dmax = 0.0_rp
    ymax = 0.0_rp
    do k = 1, size(x, 3)
      do j = 1, size(x, 2)
        do i = 1, size(x, 1)
          dmax = max(dmax, abs(x(i, j, k) - sgn * y(i, j, k)))
          ymax = max(ymax, abs(y(i, j, k)))
        end do
      end do
    end do
    same = dmax <= 1.0e-13_rp * ymax
  end function same

  !> One inner solve S dv = rhs, its iterations added to red%its; from_zero:
  !> from zero even when an inner guess was set (a retry). Collective.
  subroutine inner_solve(red, from_zero, reason, ierr)
    type(reduced_t), intent(inout) :: red
    logical, intent(in) :: from_zero
    KSPConvergedReason, intent(out) :: reason
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: its
    ierr = 0
    if (from_zero .and. guess_mode(red%gs) /= GUESS_NONE) then
      PetscCall(KSPSetInitialGuessNonzero(red%ksp, PETSC_FALSE, ierr))
    end if
    PetscCall(KSPSolve(red%ksp, red%rhs, red%dv, ierr))
    PetscCall(KSPGetConvergedReason(red%ksp, reason, ierr))
    PetscCall(KSPGetIterationNumber(red%ksp, its, ierr))
    red%its = red%its + its
  end subroutine inner_solve

  !> PCSHELL apply: du = J^{-1} b by elimination, up to the inner solve's
  !> tolerance. A failed inner solve is retried once with a freshly built
  !> preconditioner when it was a reused one; if it still fails, the PC
  !> reports failure and SNES fails the step (TS then retries it smaller).
  module subroutine reduced_pc_apply(pc, b, du, ierr)
    type(tPC) :: pc
    type(tVec) :: b, du
    PetscErrorCode :: ierr
    KSPConvergedReason :: reason
    real(rp) :: bnorm                      !< ||rhs||_2
    type(reduced_t), pointer :: red
    type(c_ptr) :: ctx                     !< the shell's context: the record's address

    PetscCall(PCShellGetContext(pc, ctx, ierr))
    call c_f_pointer(ctx, red)
    PetscCall(set_inner_rtol(red, ierr))
    PetscCall(reduced_rhs(red, b, red%rhs, ierr))
    ! (the inner solves leave rhs as it is: its norm serves the guess, the
    ! second correction kept and the relative residual below)
    PetscCall(VecNorm(red%rhs, NORM_2, bnorm, ierr))
    PetscCall(solve_s(red, bnorm, reason, ierr))
    ! PETSc keeps a PC's failure until its next set-up, which this shell
    ! PC (its matrix unchanged) never gets: set it each time, or one
    ! failed inner solve would fail every retry of the step after it
    if (reason < 0) then
      PetscCall(PCSetFailedReason(pc, PC_SUBPC_ERROR, ierr))
    else
      PetscCall(PCSetFailedReason(pc, PC_NOERROR, ierr))
    end if
    PetscCall(back_substitute(red, b, du, ierr))
  end subroutine reduced_pc_apply

  !> The inner rtol of this solve. Eisenstat-Walker sets the outer KSP's
  !> rtol: that is the forcing term; otherwise the Newton iteration's own
  !> (newton_policy: set_newton_forcing, taken once), unless
  !> -reduced_ksp_rtol fixes it.
  subroutine set_inner_rtol(red, ierr)
    type(reduced_t), intent(inout) :: red
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: rtol, atol, dtol
    PetscInt :: maxit
    PetscBool :: ew
    ierr = 0
    if (red%forward_ew) then
      PetscCall(KSPGetTolerances(red%outer, rtol, atol, dtol, maxit, ierr))
      PetscCall(SNESKSPGetUseEW(red%snes, ew, ierr))
      if (.not. ew) rtol = merge(red%eta, red%rtol0, red%eta > 0.0_rp)
      PetscCall(KSPSetTolerances(red%ksp, rtol, PETSC_DEFAULT_REAL, PETSC_DEFAULT_REAL, PETSC_DEFAULT_INTEGER, ierr))
    end if
    red%eta = 0.0_rp
  end subroutine set_inner_rtol

  !> S dv = rhs (bnorm = ||rhs||_2) from the inner guess, if any: a
  !> guessed solve that fails is done again from zero (a guess must never
  !> fail a step), and a solve with a reused preconditioner that fails
  !> again with a fresh one. The guesses keep what the converged solves
  !> give; lin_rel takes the relative residual left. reason: the last
  !> solve's. Collective.
  subroutine solve_s(red, bnorm, reason, ierr)
    type(reduced_t), intent(inout) :: red
    real(rp), intent(in) :: bnorm
    KSPConvergedReason, intent(out) :: reason
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: nit
    PetscBool :: reused
    real(rp) :: rnorm
    logical :: guessed

    PetscCall(SNESGetIterationNumber(red%snes, nit, ierr))
    guessed = .false.
    if (guess_mode(red%gs) /= GUESS_NONE) then
      PetscCall(guess_set(red%gs, red%ksp, red%a, int(nit), red%rhs, bnorm, red%dv, guessed, ierr))
    end if
    PetscCall(inner_solve(red, .false., reason, ierr))
    if (reason < 0 .and. guessed) then
      ! a guess must never fail a step: from zero once more
      PetscCall(inner_solve(red, .true., reason, ierr))
    end if
    if (reason > 0) then
      ! (a failed solve's correction is no guess)
      PetscCall(guess_keep(red%gs, red%a, int(nit), red%rhs, bnorm, red%dv, ierr))
      PetscCall(watch_cycles(red, reason, ierr))
    end if
    PetscCall(KSPGetResidualNorm(red%ksp, rnorm, ierr))
    red%lin_rel = 0.0_rp
    if (bnorm > 0.0_rp) red%lin_rel = rnorm / bnorm
    if (reason < 0) then
      PetscCall(KSPGetReusePreconditioner(red%ksp, reused, ierr))
      if (reused) then
        call reuse_rebuilt(red%pcc%reuse)
        PetscCall(KSPSetReusePreconditioner(red%ksp, PETSC_FALSE, ierr))
        PetscCall(pair_op_set_operators(red%pop, red%s, red%ksp, ierr))
        if (red%pcc%use_mg) then
          PetscCall(mg_coarse_levels(red%mgg, red%nodal, red%el%ujac, red%el%fixedg, red%a, red%el%damping, red%el%clamp, red%el%gauss_newton, ierr))
        end if
        PetscCall(inner_solve(red, .true., reason, ierr))
      end if
    end if
    ! (a pair of any converged solve, whichever Newton iteration and start)
    if (reason > 0) then
      PetscCall(guess_push(red%gs, red%a, red%rhs, bnorm, red%dv, ierr))
    end if
  end subroutine solve_s

  !> The converged solve's cycles a decade to the reuse safeguard (module
  !> pc_reuse): it asks for a rebuild at the next assembly when they grew.
  subroutine watch_cycles(red, reason, ierr)
    type(reduced_t), intent(inout) :: red
    KSPConvergedReason, intent(in) :: reason
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: its, maxit
    real(rp) :: rtol, atol, dtol
    PetscCall(KSPGetIterationNumber(red%ksp, its, ierr))
    PetscCall(KSPGetTolerances(red%ksp, rtol, atol, dtol, maxit, ierr))
    call reuse_watch(red%pcc%reuse, int(its), rtol, reason == KSP_CONVERGED_RTOL)
  end subroutine watch_cycles

  !> The back-substitution: du from the inner solution dv and the 6-dof
  !> right-hand side b (global, dof 6): dv and dx = (dv + b_x)/a on free
  !> nodes, b / a on constrained ones.
  subroutine back_substitute(red, b, du, ierr)
    type(reduced_t), intent(inout) :: red
    type(tVec) :: b, du
    PetscErrorCode, intent(out) :: ierr
    PetscScalar, pointer :: bl(:, :, :), y(:, :, :), dv(:, :, :)
    real(rp) :: ainv
    integer :: i, j
    ainv = 1.0_rp / red%a
    PetscCall(DMDAVecGetArrayReadF90(red%da6, b, bl, ierr))
    PetscCall(DMDAVecGetArrayReadF90(red%da3, red%dv, dv, ierr))
    PetscCall(DMDAVecGetArrayF90(red%da6, du, y, ierr))
    do j = red%lat%ys, red%lat%ye
      do i = 0, red%lat%nx - 1
        if (red%el%fixedg(i, j)) then
          ! J = a I on a constrained node, whose rows and columns of S
          ! couple nothing: du = b / a exactly, whatever the inner solve's
          ! tolerance and the precision of its product left in dv there
          y(:, i, j) = ainv * bl(:, i, j)
        else
          y(3:5, i, j) = dv(0:2, i, j)
          y(0:2, i, j) = ainv * (dv(0:2, i, j) + bl(0:2, i, j))
        end if
      end do
    end do
    PetscCall(DMDAVecRestoreArrayF90(red%da6, du, y, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(red%da3, red%dv, dv, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(red%da6, b, bl, ierr))
  end subroutine back_substitute

  !> MATSHELL mult: y = J du, the exact 6-dof Jacobian at the last assembled
  !> state (x-rows a dx - dv, v-rows a dv - (K dx + C dv)/m; a I on
  !> constrained rows). Collective (one halo exchange of du).
  module subroutine reduced_jac_mult(mat, du, yv, ierr)
    type(tMat) :: mat
    type(tVec) :: du, yv
    PetscErrorCode :: ierr
    type(reduced_t), pointer :: red
    type(tVec) :: dloc
    PetscScalar, pointer :: d(:, :, :), y(:, :, :)
    integer :: i, j
    real(rp) :: a
    type(c_ptr) :: ctx                     !< the shell's context: the record's address

    PetscCall(MatShellGetContext(mat, ctx, ierr))
    call c_f_pointer(ctx, red)
    a = red%a
    PetscCall(ghosted_get(red%da6, du, dloc, d, ierr))
    call element_products(red, d)
    PetscCall(pair_products(red, d, ierr))
    PetscCall(DMDAVecGetArrayF90(red%da6, yv, y, ierr))
    do j = red%lat%ys, red%lat%ye
      do i = 0, red%lat%nx - 1
        if (red%el%fixedg(i, j)) then
          y(:, i, j) = a * d(:, i, j)
        else
          y(0:2, i, j) = a * d(0:2, i, j) - d(3:5, i, j)
          y(3:5, i, j) = a * d(3:5, i, j) + red%el%g(:, i, j) / red%lat%mass(i, j)
        end if
      end do
    end do
    PetscCall(DMDAVecRestoreArrayF90(red%da6, yv, y, ierr))
    PetscCall(ghosted_restore(red%da6, dloc, d, ierr))
  end subroutine reduced_jac_mult

end submodule reduced_elim
