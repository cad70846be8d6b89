! SPDX-License-Identifier: BSD-2-Clause
!> The inner solve's initial guesses (-nuno_inner_guess): the PETSc side of
!> the kernel module inner_guess. It keeps the corrections of earlier inner
!> solves and forms a guess for the next one from them. Its record
!> (guess_t) has private components: only this module writes it. The reduced solve (module reduced) calls it
!> around each inner solve with the shift a of S [1/time], the right-hand
!> side rhs and the solution dv (3-dof vectors).
module reduced_guess
#include "petsc/finclude/petscksp.h"
  use petscksp
  use kinds, only: rp
  use inner_guess, only: GUESS_NONE, GUESS_PREVIOUS, GUESS_EXTRAPOLATE, GUESS_PROJECT, PROJECT_PAIRS, &
                         guess_weights, second_weight, projection_weights
  implicit none
  private
  public :: guess_t, guess_use, guess_free, guess_restart, guess_set, guess_keep, guess_push, guess_accepted, guess_mode

  !> The kept corrections. At a step's first Newton iteration: the first
  !> corrections of the last two steps of this time window and their
  !> shifts; at its second: the last accepted step's second correction,
  !> scaled by the ratio of the right-hand sides (second_weight). With
  !> GUESS_PROJECT: the last np inner solves at shift pa, their right-hand
  !> sides pb(k) and solutions px(k) (oldest first), the Gram matrix of the
  !> pb and their products pd with this solve's right-hand side (formed by
  !> project_guess, which every solve calls first).
  type :: guess_t
    private
    integer :: mode = GUESS_NONE           !< GUESS_NONE, _PREVIOUS, _EXTRAPOLATE or _PROJECT
    type(tVec) :: dvh(2)                   !< dvh(1) the last step's first correction, dvh(2) the one before
    real(rp) :: ah(2) = 0                  !< their shifts a [1/time]
    integer :: nh = 0                      !< how many are stored (0 at every window start)
    integer :: power = 2                   !< dv ~ 1/a^p: 2 with the extrapolated start of beuler, 1 without
    logical :: window_start = .true.       !< the next step is its window's first (TS restarts it unextrapolated)
    type(tVec) :: dvp                      !< the first correction of the step under way (kept if it is accepted)
    real(rp) :: ap = 0                     !< its shift
    logical :: pending = .false.           !< dvp holds one
    type(tVec) :: dvh2                     !< the last step's second correction
    real(rp) :: ah2 = 0                    !< its shift
    real(rp) :: bh2 = 0                    !< the norm of its right-hand side
    logical :: has2 = .false.              !< dvh2 holds one (false at every window start)
    type(tVec) :: dvp2                     !< the second correction of the step under way
    real(rp) :: ap2 = 0                    !< its shift
    real(rp) :: bp2 = 0                    !< the norm of its right-hand side
    logical :: pending2 = .false.          !< dvp2 holds one
    integer :: np = 0
    type(tVec) :: pb(PROJECT_PAIRS), px(PROJECT_PAIRS)
    real(rp) :: pg(PROJECT_PAIRS, PROJECT_PAIRS) = 0
    real(rp) :: pd(PROJECT_PAIRS) = 0
    real(rp) :: pa = 0                     !< [1/time]
  end type guess_t

contains

  !> The mode in use (for the description of the solver).
  pure integer function guess_mode(gs)
    type(guess_t), intent(in) :: gs
    guess_mode = gs%mode
  end function guess_mode

  !> Use the inner initial guess mode (GUESS_NONE, _PREVIOUS, _EXTRAPOLATE,
  !> _PROJECT; timestepping decides, from -nuno_inner_guess and the TS type).
  !> Its two kept first corrections and the step under way's, and the kept
  !> second correction and the step under way's, are five vectors like
  !> template, made here when needed. Collective.
  subroutine guess_use(gs, mode, extrapolated_start, template, ierr)
    type(guess_t), intent(inout) :: gs
    integer, intent(in) :: mode
    logical, intent(in) :: extrapolated_start      !< the TS starts Newton from x + dt xdot (but at a window's first step)
    type(tVec), intent(in) :: template
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    if (mode == GUESS_PROJECT .and. gs%mode == GUESS_NONE) then
      PetscCall(VecDuplicateVecs(template, PROJECT_PAIRS, gs%pb, ierr))
      PetscCall(VecDuplicateVecs(template, PROJECT_PAIRS, gs%px, ierr))
    else if (mode /= GUESS_NONE .and. gs%mode == GUESS_NONE) then
      PetscCall(VecDuplicate(template, gs%dvh(1), ierr))
      PetscCall(VecDuplicate(template, gs%dvh(2), ierr))
      PetscCall(VecDuplicate(template, gs%dvp, ierr))
      PetscCall(VecDuplicate(template, gs%dvh2, ierr))
      PetscCall(VecDuplicate(template, gs%dvp2, ierr))
    end if
    gs%mode = mode
    gs%power = merge(2, 1, extrapolated_start)
    gs%nh = 0
    gs%np = 0
    gs%pending = .false.
    gs%has2 = .false.
    gs%pending2 = .false.
  end subroutine guess_use

  subroutine guess_free(gs, ierr)
    type(guess_t), intent(inout) :: gs
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    if (gs%mode == GUESS_PROJECT) then
      PetscCall(VecDestroyVecs(PROJECT_PAIRS, gs%pb, ierr))
      PetscCall(VecDestroyVecs(PROJECT_PAIRS, gs%px, ierr))
    else if (gs%mode /= GUESS_NONE) then
      PetscCall(VecDestroy(gs%dvh(1), ierr))
      PetscCall(VecDestroy(gs%dvh(2), ierr))
      PetscCall(VecDestroy(gs%dvp, ierr))
      PetscCall(VecDestroy(gs%dvh2, ierr))
      PetscCall(VecDestroy(gs%dvp2, ierr))
    end if
  end subroutine guess_free

  !> A time window starts: nothing kept counts any more.
  subroutine guess_restart(gs)
    type(guess_t), intent(inout) :: gs
    gs%nh = 0
    gs%np = 0
    gs%window_start = .true.
    gs%pending = .false.
    gs%has2 = .false.
    gs%pending2 = .false.
  end subroutine guess_restart

  !> The inner initial guess of this solve, into dv: at a step's first
  !> Newton iteration (nit = 0) the combination of the stored first
  !> corrections (module inner_guess), at its second (nit = 1) the last
  !> step's second correction scaled by the ratio of their right-hand sides
  !> (second_weight), else zero; with GUESS_PROJECT the projection on the
  !> kept solves. bnorm: the norm of rhs. Sets the KSP's nonzero-guess flag.
  !> Collective.
  subroutine guess_set(gs, ksp, a, nit, rhs, bnorm, dv, guessed, ierr)
    type(guess_t), intent(inout) :: gs
    type(tKSP), intent(in) :: ksp
    real(rp), intent(in) :: a                     !< shift of S [1/time]
    integer, intent(in) :: nit
    type(tVec), intent(in) :: rhs, dv
    real(rp), intent(in) :: bnorm
    logical, intent(out) :: guessed               !< a nonzero guess was set
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: c(2)
    guessed = .false.
    c = 0.0_rp
    if (gs%mode == GUESS_PROJECT) then
      PetscCall(project_guess(gs, a, rhs, dv, guessed, ierr))
      PetscCall(KSPSetInitialGuessNonzero(ksp, merge(PETSC_TRUE, PETSC_FALSE, guessed), ierr))
      return
    end if
    if (nit == 0) then
      c = guess_weights(gs%mode, gs%nh, a, gs%ah(1), gs%ah(2), gs%power)
    else if (nit == 1 .and. gs%has2) then
      c(1) = second_weight(a, gs%ah2, bnorm, gs%bh2)
    end if
    if (c(1) == 0.0_rp .and. c(2) == 0.0_rp) then
      PetscCall(KSPSetInitialGuessNonzero(ksp, PETSC_FALSE, ierr))
      return
    end if
    if (nit == 1) then
      PetscCall(VecAXPBY(dv, c(1), 0.0_rp, gs%dvh2, ierr))
    else if (c(2) == 0.0_rp) then
      PetscCall(VecAXPBY(dv, c(1), 0.0_rp, gs%dvh(1), ierr))
    else
      PetscCall(VecAXPBYPCZ(dv, c(1), c(2), 0.0_rp, gs%dvh(1), gs%dvh(2), ierr))
    end if
    PetscCall(KSPSetInitialGuessNonzero(ksp, PETSC_TRUE, ierr))
    guessed = .true.
  end subroutine guess_set

  !> -nuno_inner_guess project: dv = sum_k y_k px(k), y the least-squares
  !> weights of the kept right-hand sides for this one (projection_weights),
  !> at any Newton iteration; nothing kept at this shift: no guess. The
  !> products pd are kept for project_push. Collective.
  subroutine project_guess(gs, a, rhs, dv, guessed, ierr)
    type(guess_t), intent(inout) :: gs
    real(rp), intent(in) :: a
    type(tVec), intent(in) :: rhs, dv
    logical, intent(out) :: guessed
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: y(PROJECT_PAIRS)
    ierr = 0
    guessed = .false.
    if (gs%np == 0 .or. a /= gs%pa) return
    PetscCall(VecMDot(rhs, gs%np, gs%pb, gs%pd, ierr))
    call projection_weights(gs%np, gs%pg, gs%pd, y)
    if (all(y(1:gs%np) == 0.0_rp)) return
    PetscCall(VecSet(dv, 0.0_rp, ierr))
    PetscCall(VecMAXPY(dv, gs%np, y, gs%px, ierr))
    guessed = .true.
  end subroutine project_guess

  !> A converged inner solve (rhs, its norm bnorm, its solution dv, at
  !> Newton iteration nit and shift a) is kept as the mode needs: its first
  !> and second corrections until the step is accepted (guess_accepted; a
  !> failed solve's is no guess), or with GUESS_PROJECT the pair of any
  !> converged solve, whichever Newton iteration and start. Collective.
  subroutine guess_keep(gs, a, nit, rhs, bnorm, dv, ierr)
    type(guess_t), intent(inout) :: gs
    real(rp), intent(in) :: a
    integer, intent(in) :: nit
    type(tVec), intent(in) :: rhs, dv
    real(rp), intent(in) :: bnorm
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    if (gs%mode == GUESS_PREVIOUS .or. gs%mode == GUESS_EXTRAPOLATE) then
      if (nit == 0) then
        ! this step's first correction, kept if the step is accepted
        PetscCall(VecCopy(dv, gs%dvp, ierr))
        gs%ap = a
        gs%pending = .true.
        gs%pending2 = .false.
      else if (nit == 1) then
        ! and its second, for the next step's second iteration
        PetscCall(VecCopy(dv, gs%dvp2, ierr))
        gs%bp2 = bnorm
        gs%ap2 = a
        gs%pending2 = .true.
      end if
    end if
  end subroutine guess_keep

  !> -nuno_inner_guess project: a converged inner solve (rhs, its norm
  !> bnorm, and dv) joins the kept ones, the oldest leaving when PROJECT_PAIRS
  !> are kept (the vectors change places, no copies but the new pair's);
  !> its products with them, pd, are project_guess's for this solve. A
  !> changed shift (another dt: S differs by more than a step's change)
  !> empties them first. Collective.
  subroutine guess_push(gs, a, rhs, bnorm, dv, ierr)
    type(guess_t), intent(inout) :: gs
    real(rp), intent(in) :: a
    type(tVec), intent(in) :: rhs, dv
    real(rp), intent(in) :: bnorm
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: sb, sx
    integer :: k, n
    ierr = 0
    if (gs%mode /= GUESS_PROJECT) return
    if (a /= gs%pa) gs%np = 0
    gs%pa = a
    n = gs%np
    if (n == PROJECT_PAIRS) then
      sb = gs%pb(1)
      sx = gs%px(1)
      do k = 1, n - 1
        gs%pb(k) = gs%pb(k + 1)
        gs%px(k) = gs%px(k + 1)
      end do
      gs%pb(n) = sb
      gs%px(n) = sx
      gs%pg(1:n - 1, 1:n - 1) = gs%pg(2:n, 2:n)
      gs%pd(1:n - 1) = gs%pd(2:n)
      n = n - 1
    end if
    n = n + 1
    PetscCall(VecCopy(rhs, gs%pb(n), ierr))
    PetscCall(VecCopy(dv, gs%px(n), ierr))
    gs%pg(n, 1:n - 1) = gs%pd(1:n - 1)
    gs%pg(1:n - 1, n) = gs%pd(1:n - 1)
    gs%pg(n, n) = bnorm**2
    gs%np = n
  end subroutine guess_push

  !> A step was accepted (timestepping's monitor): its first correction
  !> joins the two kept for the next guesses, and its second, where it
  !> took a second Newton iteration, replaces the one kept. Only accepted
  !> steps count: a rejected attempt's correction starts at the same time as
  !> its retry's, so extrapolating through it would be nonsense. A window's
  !> first step, which TS starts from the last state rather than
  !> extrapolated, gives another quantity: not kept.
  subroutine guess_accepted(gs)
    type(guess_t), intent(inout) :: gs
    type(tVec) :: spare
    logical :: second
    if (gs%mode == GUESS_NONE .or. .not. gs%pending) return
    gs%pending = .false.
    second = gs%pending2
    gs%pending2 = .false.
    if (gs%window_start) then
      gs%window_start = .false.
      if (gs%power == 2) return
    end if
    if (second) then
      spare = gs%dvh2
      gs%dvh2 = gs%dvp2
      gs%dvp2 = spare
      gs%ah2 = gs%ap2
      gs%bh2 = gs%bp2
      gs%has2 = .true.
    end if
    ! the vectors change places, no copies
    spare = gs%dvh(2)
    gs%dvh(2) = gs%dvh(1)
    gs%dvh(1) = gs%dvp
    gs%dvp = spare
    gs%ah(2) = gs%ah(1)
    gs%ah(1) = gs%ap
    gs%nh = min(gs%nh + 1, 2)
  end subroutine guess_accepted
end module reduced_guess
