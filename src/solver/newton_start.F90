! SPDX-License-Identifier: BSD-2-Clause
!> The Newton start of backward Euler from the last accepted states
!> (-nuno_newton_start; docs/design.md, "the cubic start"): the states it
!> keeps, the SNES initial-guess callback, and the accessors through which
!> the monitor, the window loop and the checkpoints reach the states. The
!> arithmetic's weights and the safeguard's rules are kernel
!> start_predictor (PETSc-free, unit-tested).
!>
!> PETSc's beuler starts Newton from x_n + dt xdot_n, the last two states
!> extrapolated linearly (-ts_theta_initial_guess_extrapolate). With the
!> cubic start Newton starts from the polynomial through the last four
!> accepted states at t_n, t_n - dt, t_n - 2 dt, t_n - 3 dt, evaluated at
!> t_n + dt (quadratic, linear while fewer equally spaced states are at
!> hand). On hang 257 x 257 (dt = 1 ms) the first residual of a step is
!> then 100-150 times smaller than from the linear start, and Newton takes
!> one iteration a step instead of two (measured with commit 9f1bf04).
!>
!> A limited start (process models that need a feasible start: contact;
!> issue 47 items 4 and 6): whatever the start, x_n + alpha (x - x_n)
!> with the largest alpha <= 1 their step limit allows from x_n (module
!> process_solver's limiter), so that it is feasible by construction and
!> as close to the predictor as the obstacles let it be; any TS type
!> (beuler's extrapolated or cubic start, bdf's extrapolated history). A
!> retried step starts from x_n itself (its predictor may be a failed
!> iterate's).
!>
!> PETSc 3.18's Fortran interface has no SNESSetComputeInitialGuess (a C
!> function pointer) nor SNESSetInitialFunction: src/solver/nuno_newton_start.c
!> registers a C trampoline that calls newton_start_guess with this
!> module's record as the context.
module newton_start
#include "petsc/finclude/petscts.h"
  use petscts
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_intptr_t, c_ptr, c_loc, c_f_pointer
  use kinds, only: rp
  use solver_choices, only: START_AUTO, START_LINEAR, START_CUBIC, START_CONSISTENT, START_NAMES
  use start_predictor, only: START_KEPT, start_spaced, start_weights, start_linear_weights, start_needs_linear, start_pick
  implicit none
  private
  public :: newton_start_t, newton_start_setup, newton_start_free, newton_start_order, newton_start_is_consistent, &
            newton_start_limited, &
            start_limit_i, newton_start_smooth_limited, start_consistent_i, newton_start_consistent
  public :: newton_start_push, newton_start_reset, newton_start_count, newton_start_get, newton_start_put

  !> The kept states and the safeguard's state. Written only by this
  !> module; the callback's context, so at a fixed address for the life of
  !> the TS (a component of the solver's context).
  type :: newton_start_t
    private
    logical :: on = .false.                     !< the cubic start is in use
    integer :: order = 1                        !< 1 (linear) or 3 (cubic)
    type(tTS) :: ts                             !< not owned
    integer :: n = 0                            !< states kept, newest first
    logical :: made = .false.                   !< h created
    type(tVec) :: h(START_KEPT)                 !< 6-dof states x_n, x_{n-1}, ...
    real(rp) :: t(START_KEPT) = 0               !< their times [time]
    logical :: work = .false.                   !< xl, fl, fc created
    type(tVec) :: xl, fl, fc                    !< the linear start, its residual; the polynomial start's residual
    logical :: compare = .true.                 !< evaluate the linear start too (start_needs_linear)
    real(rp) :: nc_prev = 0                     !< ||F|| of the last polynomial start
    logical :: installed = .false.              !< the SNES's initial-guess callback is this module's
    !> the limiter of a feasible start (newton_start_limited), with its context
    procedure(start_limit_i), pointer, nopass :: limit => null()
    type(c_ptr) :: limit_ctx
    !> the positions of a polynomial start made consistent with its
    !> velocities (newton_start_consistent), with its context
    procedure(start_consistent_i), pointer, nopass :: consistent => null()
    type(c_ptr) :: consistent_ctx
    logical :: make_consistent = .false.        !< -nuno_newton_start consistent
    PetscInt :: last_step = -1, last_rejects = -1   !< the TS's step and rejections at the last start
    logical :: lwork = .false.                  !< x0w, f0w created
    type(tVec) :: x0w, f0w                      !< the step's start x_n and its residual (limited_pick)
    integer :: starts_at_xn = 0                 !< limited starts that took x_n (its residual the smaller)
    logical :: cut = .false.                    !< the limiter cut this step's start
    real(rp) :: nstart_prev = 0                 !< ||F|| at the last step's limited start
  end type newton_start_t

  abstract interface
    !> A limited start: x becomes x0 + alpha (x - x0), x0 the step's start
    !> (the TS's solution), alpha the largest fraction the limiter's
    !> owner allows (0 when none); cut: alpha < 1. Collective.
    subroutine start_limit_i(ctx, x, cut, ierr)
      import :: c_ptr, tVec
      type(c_ptr), value :: ctx
      type(tVec) :: x
      logical, intent(out) :: cut
      PetscErrorCode, intent(out) :: ierr
    end subroutine start_limit_i
    !> The start x's positions made those backward Euler's position rows
    !> take from its velocities and the step's start x_n (x = x_n + dt v;
    !> a prescribed node's x_n + dt vbar). Collective.
    subroutine start_consistent_i(ctx, x, ierr)
      import :: c_ptr, tVec
      type(c_ptr), value :: ctx
      type(tVec) :: x
      PetscErrorCode, intent(out) :: ierr
    end subroutine start_consistent_i
  end interface

  interface
    !> src/solver/nuno_newton_start.c: SNESSetComputeInitialGuess with the C
    !> trampoline that calls newton_start_guess(snes, x, ctx).
    integer(c_int) function nuno_snes_set_initial_guess(snes, ctx) bind(C, name='nuno_snes_set_initial_guess')
      import :: c_int, c_intptr_t, c_ptr
      integer(c_intptr_t) :: snes                !< SNES*
      type(c_ptr), value :: ctx
    end function nuno_snes_set_initial_guess
    !> src/solver/nuno_newton_start.c: SNESSetInitialFunction.
    integer(c_int) function nuno_snes_set_initial_function(snes, f) bind(C, name='nuno_snes_set_initial_function')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: snes, f             !< SNES*, Vec*
    end function nuno_snes_set_initial_function
    !> src/solver/nuno_options.c: -nuno_newton_start in an options block (in -help);
    !> choice in/out: a code, the position in names.
    integer(c_int) function nuno_newton_start_option(fcomm, names, nnames, namelen, choice) &
        bind(C, name='nuno_newton_start_option')
      import :: c_int, c_char
      integer(c_int), value :: fcomm, nnames, namelen
      character(kind=c_char), intent(in) :: names(*)
      integer(c_int), intent(inout) :: choice
    end function nuno_newton_start_option
  end interface

contains

  !> Read -nuno_newton_start (auto, linear, cubic, consistent) and, for
  !> cubic or consistent, put the start on the TS's SNES. auto_cubic: auto
  !> is consistent for this run, else linear (module newton_policy).
  !> Refuses cubic and consistent with a TS other than beuler,
  !> whose stage solved by Newton is then not the state at t_n + dt.
  !> s must stay at its address while the TS lives. Collective.
  subroutine newton_start_setup(s, ts, comm, auto_cubic, ierr)
    type(newton_start_t), intent(inout), target :: s
    type(tTS), intent(in) :: ts
    integer, intent(in) :: comm                  !< the TS's
    logical, intent(in) :: auto_cubic
    PetscErrorCode, intent(out) :: ierr
    integer(c_int) :: choice
    PetscBool :: beuler
    type(tSNES) :: snes

    choice = START_AUTO
    ierr = nuno_newton_start_option(comm, START_NAMES, size(START_NAMES), len(START_NAMES), choice)
    if (ierr /= 0) return
    PetscCall(PetscObjectTypeCompare(ts, TSBEULER, beuler, ierr))
    if (choice == START_CUBIC .and. .not. beuler) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, '-nuno_newton_start cubic needs -ts_type beuler (its Newton solve is for the state at t + dt)')
    end if
    if (choice == START_CONSISTENT .and. .not. beuler) then
      ierr = PETSC_ERR_ARG_INCOMP
      SETERRQ(comm, ierr, '-nuno_newton_start consistent needs -ts_type beuler (its positions are x_n + dt v)')
    end if
    s%order = 1
    s%make_consistent = .false.
    if (choice == START_LINEAR .or. (choice == START_AUTO .and. .not. (auto_cubic .and. beuler))) return
    ! auto's polynomial start is the consistent one (a free falling sheet
    ! at 129 x 129: 1.02 Newton iterations a step instead of cubic's 1.95)
    s%make_consistent = choice == START_CONSISTENT .or. choice == START_AUTO
    s%on = .true.
    s%ts = ts
    s%n = 0
    s%compare = .true.
    s%nc_prev = 0.0_rp
    PetscCall(install(s, ts, ierr))
    s%order = 3
  end subroutine newton_start_setup

  !> Every Newton start from now on limited by limit (with its context
  !> ctx): feasible for the process models (module process_solver). Any TS
  !> type. s must stay at its address while the TS lives. Collective.
  subroutine newton_start_limited(s, ts, limit, ctx, ierr)
    type(newton_start_t), intent(inout), target :: s
    type(tTS), intent(in) :: ts
    procedure(start_limit_i) :: limit
    type(c_ptr), intent(in) :: ctx
    PetscErrorCode, intent(out) :: ierr
    s%limit => limit
    s%limit_ctx = ctx
    PetscCall(install(s, ts, ierr))
  end subroutine newton_start_limited

  !> With -nuno_newton_start consistent, the polynomial starts' positions
  !> made consistent with their velocities by consistent (with its
  !> context ctx) before any limiter:
  !> the cubic start extrapolates positions and velocities apart, and its
  !> positions' miss of backward Euler's x = x_n + dt v, which the first
  !> Newton iteration puts right in full, moves the nonlinear forces (a
  !> barrier's most) by more than the velocities' miss does (docs/
  !> performance.md, open problem 6). s must stay at its address while the
  !> TS lives.
  subroutine newton_start_consistent(s, consistent, ctx)
    type(newton_start_t), intent(inout), target :: s
    procedure(start_consistent_i) :: consistent
    type(c_ptr), intent(in) :: ctx
    s%consistent => consistent
    s%consistent_ctx = ctx
  end subroutine newton_start_consistent

  !> This module's callback as the SNES's initial guess (once).
  subroutine install(s, ts, ierr)
    type(newton_start_t), intent(inout), target :: s
    type(tTS), intent(in) :: ts
    PetscErrorCode, intent(out) :: ierr
    type(tSNES) :: snes
    ierr = 0
    s%ts = ts
    if (s%installed) return
    PetscCall(TSGetSNES(ts, snes, ierr))
    ierr = nuno_snes_set_initial_guess(snes%v, c_loc(s))
    if (ierr /= 0) return
    s%installed = .true.
  end subroutine install

  !> 1 (PETSc's linear start) or 3 (the cubic start).
  pure integer function newton_start_order(s)
    type(newton_start_t), intent(in) :: s
    newton_start_order = s%order
  end function newton_start_order

  !> The polynomial start's positions are made consistent with its
  !> velocities (-nuno_newton_start consistent, auto's choice).
  pure logical function newton_start_is_consistent(s)
    type(newton_start_t), intent(in) :: s
    newton_start_is_consistent = s%on .and. s%make_consistent
  end function newton_start_is_consistent

  !> The cubic start limited by a process model's step limit is in use
  !> (its hint smooth_start): the start can be at the residual's floor,
  !> and Newton's convergence test takes the update's floor too (module
  !> newton_policy).
  pure logical function newton_start_smooth_limited(s)
    type(newton_start_t), intent(in) :: s
    newton_start_smooth_limited = s%on .and. associated(s%limit)
  end function newton_start_smooth_limited

  !> Destroy the kept states and work vectors (before the TS: nothing
  !> calls the start afterwards). Collective.
  subroutine newton_start_free(s, ierr)
    type(newton_start_t), intent(inout) :: s
    PetscErrorCode, intent(out) :: ierr
    integer :: k
    ierr = 0
    if (s%made) then
      do k = 1, START_KEPT
        PetscCall(VecDestroy(s%h(k), ierr))
      end do
    end if
    if (s%work) then
      PetscCall(VecDestroy(s%xl, ierr))
      PetscCall(VecDestroy(s%fl, ierr))
      PetscCall(VecDestroy(s%fc, ierr))
    end if
    if (s%lwork) then
      PetscCall(VecDestroy(s%x0w, ierr))
      PetscCall(VecDestroy(s%f0w, ierr))
    end if
    s%made = .false.
    s%work = .false.
    s%lwork = .false.
    s%on = .false.
    s%n = 0
  end subroutine newton_start_free

  !> x = sum_k w(k) h(k) over the newest size(w) kept states, grouped two
  !> terms a call (VecAXPBYPCZ) and a last odd one by VecAXPY, left to right.
  subroutine combine(s, w, x, ierr)
    type(newton_start_t), intent(in) :: s
    real(rp), intent(in) :: w(:)
    type(tVec), intent(inout) :: x
    PetscErrorCode, intent(out) :: ierr
    integer :: k
    PetscCall(VecAXPBYPCZ(x, w(1), w(2), 0.0_rp, s%h(1), s%h(2), ierr))
    k = 3
    do while (k + 1 <= size(w))
      PetscCall(VecAXPBYPCZ(x, w(k), w(k + 1), 1.0_rp, s%h(k), s%h(k + 1), ierr))
      k = k + 2
    end do
    if (k == size(w)) then
      PetscCall(VecAXPY(x, w(k), s%h(k), ierr))
    end if
  end subroutine combine

  !> SNESSetComputeInitialGuess's callback (through the C trampoline): x is
  !> the start TS set (x_n, or x_n + dt xdot_n, or bdf's extrapolated
  !> history). With the cubic start, when the kept states end at this
  !> step's start and are spaced by its dt, x becomes the polynomial
  !> through them (polynomial_start). A step of another dt (a retry after a
  !> failed solve, a sliver before a stop time) starts from the last two
  !> accepted states extrapolated linearly to it (TS's xdot may then be a
  !> failed iterate's). With a limiter (newton_start_limited) every start
  !> is limited, and the one whose residual is smaller of it and the
  !> step's start x_n is taken (limited_pick); a retried step starts from
  !> x_n.
  subroutine newton_start_guess(snes_h, x_h, sp, ierr) bind(C, name='nuno_newton_start_guess')
    integer(c_intptr_t), intent(in) :: snes_h, x_h   !< SNES, Vec
    type(c_ptr), value :: sp                         !< the newton_start_t
    integer(c_int), intent(out) :: ierr              !< PetscErrorCode, as C's int
    type(newton_start_t), pointer :: s
    type(tSNES) :: snes
    type(tVec) :: x
    real(rp) :: t, dt, nx, w2(2)
    integer :: m
    logical :: retry, known

    ierr = 0
    call c_f_pointer(sp, s)
    snes%v = snes_h
    x%v = x_h
    PetscCall(TSGetTime(s%ts, t, ierr))
    PetscCall(TSGetTimeStep(s%ts, dt, ierr))
    PetscCall(retried(s, retry, ierr))
    if (retry .and. associated(s%limit)) then
      ! a retried step with a limited start: from x_n itself
      PetscCall(limited(s, x, 0.0_rp, ierr))
      return
    end if
    s%cut = .false.
    known = .false.
    nx = 0.0_rp
    if (.not. s%on .or. s%n < 2 .or. abs(s%t(1) - t) > 1.0e-9_rp * abs(dt)) then
      PetscCall(limited(s, x, 1.0_rp, ierr))
    else
      m = start_spaced(s%t, s%n, dt)
      if (m == 1) then
        w2 = start_linear_weights(s%t(1), s%t(2), dt)
        PetscCall(VecAXPBYPCZ(x, w2(1), w2(2), 0.0_rp, s%h(1), s%h(2), ierr))
        PetscCall(limited(s, x, 1.0_rp, ierr))
      else if (m == 2) then
        PetscCall(combine(s, start_weights(1), x, ierr))
        PetscCall(limited(s, x, 1.0_rp, ierr))
      else
        PetscCall(polynomial_start(s, snes, x, m - 1, known, nx, ierr))
      end if
    end if
    if (associated(s%limit)) then
      PetscCall(limited_pick(s, snes, x, known, nx, ierr))
    end if
  end subroutine newton_start_guess

  !> The cubic (p = 3) or quadratic (p = 2) start through the kept states
  !> into x, limited, and its residual handed to SNES (known: set, its norm
  !> nx), unless the linear start's residual is smaller (start_pick: then
  !> x is that, with its residual); both evaluated until the polynomial
  !> has won by a factor 2 (start_needs_linear). Collective.
  subroutine polynomial_start(s, snes, x, p, known, nx, ierr)
    type(newton_start_t), intent(inout) :: s
    type(tSNES), intent(in) :: snes
    type(tVec), intent(inout) :: x
    integer, intent(in) :: p
    logical, intent(out) :: known
    real(rp), intent(out) :: nx
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: nc, nl
    logical :: take_linear
    known = .false.
    nx = 0.0_rp
    if (.not. s%work) then
      PetscCall(VecDuplicate(x, s%xl, ierr))
      PetscCall(VecDuplicate(x, s%fl, ierr))
      PetscCall(VecDuplicate(x, s%fc, ierr))
      s%work = .true.
    end if
    PetscCall(combine(s, start_weights(p), x, ierr))
    if (s%make_consistent .and. associated(s%consistent)) then
      call s%consistent(s%consistent_ctx, x, ierr)
      if (ierr /= 0) return
    end if
    PetscCall(limited(s, x, 1.0_rp, ierr))
    PetscCall(SNESComputeFunction(snes, x, s%fc, ierr))
    PetscCall(VecNorm(s%fc, NORM_2, nc, ierr))
    if (start_needs_linear(s%compare, nc, s%nc_prev)) then
      PetscCall(combine(s, start_weights(1), s%xl, ierr))
      PetscCall(limited(s, s%xl, 1.0_rp, ierr))
      PetscCall(SNESComputeFunction(snes, s%xl, s%fl, ierr))
      PetscCall(VecNorm(s%fl, NORM_2, nl, ierr))
      call start_pick(nc, nl, take_linear, s%compare)
      if (take_linear) then
        PetscCall(VecCopy(s%xl, x, ierr))
        ierr = nuno_snes_set_initial_function(snes%v, s%fl%v)
        if (ierr /= 0) return
        known = .true.
        nx = nl
      end if
      ! else SNES evaluates the polynomial start's residual again: TS's
      ! Jacobian takes xdot from the last residual evaluated, which must be
      ! the start's (from the other start's, the elimination's predicted
      ! products missed, and every inner solve took a pass over the
      ! elements more: +30 ms a step at 257 x 257)
    else
      ierr = nuno_snes_set_initial_function(snes%v, s%fc%v)
      if (ierr /= 0) return
      known = .true.
      nx = nc
    end if
    s%nc_prev = nc
  end subroutine polynomial_start

  !> The residual's norm n0 at the step's start x_n (the TS's solution),
  !> kept with x_n for limited_pick (x: a vector like the state). Collective.
  subroutine start_residual(s, snes, x, n0, ierr)
    type(newton_start_t), intent(inout) :: s
    type(tSNES), intent(in) :: snes
    type(tVec), intent(in) :: x
    real(rp), intent(out) :: n0
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: x0
    logical :: cut
    if (.not. s%lwork) then
      PetscCall(VecDuplicate(x, s%x0w, ierr))
      PetscCall(VecDuplicate(x, s%f0w, ierr))
      s%lwork = .true.
    end if
    PetscCall(TSGetSolution(s%ts, x0, ierr))
    PetscCall(VecCopy(x0, s%x0w, ierr))
    call s%limit(s%limit_ctx, s%x0w, cut, ierr)     ! moved where an obstacle reaches it
    if (ierr /= 0) return
    PetscCall(SNESComputeFunction(snes, s%x0w, s%f0w, ierr))
    PetscCall(VecNorm(s%f0w, NORM_2, n0, ierr))
  end subroutine start_residual

  !> A limited start x against the step's start x_n: x's residual (known:
  !> handed to SNES already, its norm nx; else evaluated here), and where
  !> the limiter cut the start or its residual is over 4 times the last
  !> step's, x_n's too, and x_n taken where it is the smaller. A
  !> predictor that puts a node deep into a barrier (limited short of an
  !> obstacle it would cross, or landing just above one) starts Newton
  !> where the barrier's force is far off, and Newton stalled there
  !> (drape_sphere at 129 x 129 from the linear start: ||F|| 4800 for 50
  !> iterations); x_n is the state the step began from, feasible, and the
  !> start of every solve before limited starts. Elsewhere the predictor's
  !> residual is handed to SNES (no evaluation more than without the
  !> check). Collective.
  subroutine limited_pick(s, snes, x, known, nx, ierr)
    type(newton_start_t), intent(inout) :: s
    type(tSNES), intent(in) :: snes
    type(tVec), intent(inout) :: x
    logical, intent(in) :: known
    real(rp), intent(in) :: nx
    PetscErrorCode, intent(out) :: ierr
    real(rp) :: nn, n0
    ierr = 0
    nn = nx
    if (.not. known) then
      if (.not. s%work) then
        PetscCall(VecDuplicate(x, s%xl, ierr))
        PetscCall(VecDuplicate(x, s%fl, ierr))
        PetscCall(VecDuplicate(x, s%fc, ierr))
        s%work = .true.
      end if
      PetscCall(SNESComputeFunction(snes, x, s%fc, ierr))
      PetscCall(VecNorm(s%fc, NORM_2, nn, ierr))
    end if
    if (.not. (s%cut .or. nn > 4.0_rp * s%nstart_prev)) then
      s%nstart_prev = nn
      if (.not. known) ierr = nuno_snes_set_initial_function(snes%v, s%fc%v)
      return
    end if
    PetscCall(start_residual(s, snes, x, n0, ierr))
    ! (SNES evaluates the residual of the start taken again: the last
    ! evaluated, which TS's Jacobian takes its xdot from, is x_n's)
    if (n0 < nn) then
      PetscCall(VecCopy(s%x0w, x, ierr))
      s%starts_at_xn = s%starts_at_xn + 1
      s%nstart_prev = n0
    else
      s%nstart_prev = nn
    end if
  end subroutine limited_pick

  !> The start x limited (newton_start_limited; nothing without a
  !> limiter): scale 0 puts it at the step's start x_n, 1 leaves the
  !> limiter to find how far toward x it may go; either is then moved
  !> into the limiter's owner's domain (process_solver's pm_limit_start).
  !> Collective.
  subroutine limited(s, x, scale, ierr)
    type(newton_start_t), intent(inout) :: s
    type(tVec), intent(inout) :: x
    real(rp), intent(in) :: scale
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: x0
    logical :: cut
    ierr = 0
    if (.not. associated(s%limit)) return
    if (scale == 0.0_rp) then
      PetscCall(TSGetSolution(s%ts, x0, ierr))
      PetscCall(VecCopy(x0, x, ierr))
    end if
    ! (x_n too: the limiter's owner moves it into its domain, where a
    ! moving obstacle reaches it over the step)
    call s%limit(s%limit_ctx, x, cut, ierr)
    s%cut = s%cut .or. cut
  end subroutine limited

  !> This start is a retried step's (the TS rejected a step since the last
  !> start of the same step): its predictor may be a failed iterate's.
  subroutine retried(s, retry, ierr)
    type(newton_start_t), intent(inout) :: s
    logical, intent(out) :: retry
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: step, rejects
    PetscCall(TSGetStepNumber(s%ts, step, ierr))
    PetscCall(TSGetStepRejections(s%ts, rejects, ierr))
    retry = step == s%last_step .and. rejects > s%last_rejects
    s%last_step = step
    s%last_rejects = rejects
  end subroutine retried

  !> Keep the accepted state u at time t (module step_monitor; nothing
  !> without the cubic start). The vectors change places, the oldest is
  !> overwritten. Collective.
  subroutine newton_start_push(s, u, t, ierr)
    type(newton_start_t), intent(inout) :: s
    type(tVec), intent(in) :: u
    real(rp), intent(in) :: t                    !< [time]
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: oldest
    integer :: k
    ierr = 0
    if (.not. s%on) return
    if (s%n > 0 .and. t == s%t(1)) return         ! the same state again
    PetscCall(make_states(s, u, ierr))
    oldest = s%h(START_KEPT)
    do k = START_KEPT, 2, -1
      s%h(k) = s%h(k - 1)
      s%t(k) = s%t(k - 1)
    end do
    s%h(1) = oldest
    s%t(1) = t
    PetscCall(VecCopy(u, s%h(1), ierr))
    s%n = min(s%n + 1, START_KEPT)
  end subroutine newton_start_push

  !> Forget the kept states (a window's start where the state jumps: a keyframe).
  subroutine newton_start_reset(s)
    type(newton_start_t), intent(inout) :: s
    if (.not. s%on) return
    s%n = 0
    s%compare = .true.
  end subroutine newton_start_reset

  !> For a checkpoint: n, the number of kept states (0 without the cubic
  !> start), and the safeguard's state.
  subroutine newton_start_count(s, n, compare, nc_prev)
    type(newton_start_t), intent(in) :: s
    integer, intent(out) :: n
    logical, intent(out) :: compare
    real(rp), intent(out) :: nc_prev
    n = merge(s%n, 0, s%on)
    compare = s%compare .or. .not. s%on
    nc_prev = merge(s%nc_prev, 0.0_rp, s%on)
  end subroutine newton_start_count

  !> For a checkpoint: v = the kept state k (1: the newest), t its time.
  !> Collective.
  subroutine newton_start_get(s, k, v, t, ierr)
    type(newton_start_t), intent(in) :: s
    integer, intent(in) :: k
    type(tVec), intent(inout) :: v
    real(rp), intent(out) :: t                   !< [time]
    PetscErrorCode, intent(out) :: ierr
    if (.not. s%on .or. k < 1 .or. k > s%n) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(PETSC_COMM_SELF, ierr, 'newton_start_get: no such kept state')
    end if
    PetscCall(VecCopy(s%h(k), v, ierr))
    t = s%t(k)
  end subroutine newton_start_get

  !> From a checkpoint (a restart): kept state k (1: the newest) becomes v
  !> at time t, n states are kept, and the safeguard's state is put back,
  !> so that the next steps start as in the run that wrote the checkpoint.
  !> Nothing without the cubic start. Collective.
  subroutine newton_start_put(s, k, v, t, n, compare, nc_prev, ierr)
    type(newton_start_t), intent(inout) :: s
    integer, intent(in) :: k, n
    type(tVec), intent(in) :: v
    real(rp), intent(in) :: t, nc_prev
    logical, intent(in) :: compare
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    if (.not. s%on) return
    if (k < 1 .or. k > START_KEPT .or. n < 1 .or. n > START_KEPT) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(PETSC_COMM_SELF, ierr, 'newton_start_put: no such kept state')
    end if
    PetscCall(make_states(s, v, ierr))
    PetscCall(VecCopy(v, s%h(k), ierr))
    s%t(k) = t
    s%n = n
    s%compare = compare
    s%nc_prev = nc_prev
  end subroutine newton_start_put

  !> The kept states' vectors, like u, at the first state kept.
  subroutine make_states(s, u, ierr)
    type(newton_start_t), intent(inout) :: s
    type(tVec), intent(in) :: u
    PetscErrorCode, intent(out) :: ierr
    integer :: k
    ierr = 0
    if (s%made) return
    do k = 1, START_KEPT
      PetscCall(VecDuplicate(u, s%h(k), ierr))
    end do
    s%made = .true.
  end subroutine make_states

end module newton_start
