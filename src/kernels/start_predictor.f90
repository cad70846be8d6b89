! SPDX-License-Identifier: BSD-2-Clause
!> The arithmetic and the safeguard of backward Euler's Newton start from
!> the last accepted states (-nuno_newton_start; module newton_start is its
!> PETSc side, docs/design.md, "the cubic start"). Plain numbers in and
!> out: unit-tested alone (tests/unit/test_start_predictor.f90).
!>
!> The polynomial of order p through p + 1 states equally spaced by dt,
!> x_n, x_{n-1}, ..., evaluated one spacing beyond the newest, is
!> sum_k w_k x_{n-k} with the weights of start_weights: 2, -1 (linear),
!> 3, -3, 1 (quadratic), 4, -6, 4, -1 (cubic). Exact for data that are a
!> polynomial of order p in t; off by dt^(p+1) times the (p+1)-th
!> derivative otherwise.
module start_predictor
  use kinds, only: rp
  implicit none
  private
  public :: START_KEPT, start_spaced, start_weights, start_linear_weights, start_needs_linear, start_pick

  !> States kept: the cubic needs four.
  integer, parameter :: START_KEPT = 4
  !> Relative tolerance on time differences [1]: times are sums of steps, so
  !> equal spacings may differ in their last bits.
  real(rp), parameter :: TIME_TOL = 1.0e-9_rp

contains

  !> The number of kept states (times t(1:n), newest first) equally spaced
  !> by dt, counted from the newest (1: the newest alone).
  pure integer function start_spaced(t, n, dt) result(m)
    real(rp), intent(in) :: t(:)                 !< [time], newest first
    integer, intent(in) :: n                     !< states kept
    real(rp), intent(in) :: dt                   !< this step [time]
    real(rp) :: tol
    tol = TIME_TOL * abs(dt)
    do m = 1, n - 1
      if (abs(t(m) - t(m + 1) - dt) > tol) exit
    end do
  end function start_spaced

  !> w(1:p+1): the weights of the newest p + 1 states in the polynomial of
  !> order p (1, 2 or 3) through them, one spacing beyond the newest.
  pure function start_weights(p) result(w)
    integer, intent(in) :: p
    real(rp) :: w(p + 1)
    select case (p)
    case (1)
      w = [2.0_rp, -1.0_rp]
    case (2)
      w = [3.0_rp, -3.0_rp, 1.0_rp]
    case default
      w = [4.0_rp, -6.0_rp, 4.0_rp, -1.0_rp]
    end select
  end function start_weights

  !> The weights of x_n (t0) and x_{n-1} (t1) in their line through them
  !> at t0 + dt, for a step whose dt is not their spacing (a retry, a sliver
  !> before a stop time).
  pure function start_linear_weights(t0, t1, dt) result(w)
    real(rp), intent(in) :: t0, t1, dt           !< [time]
    real(rp) :: w(2)
    w(1) = 1.0_rp + dt / (t0 - t1)
    w(2) = -dt / (t0 - t1)
  end function start_linear_weights

  !> Whether the linear start's residual must be evaluated too: while the
  !> polynomial start has not won by a factor 2 (compare), or when its
  !> residual nc is more than twice the last one's, nc_prev (or not a
  !> number). In the fast transients of a membrane without bending just
  !> after a release from rest the polynomial's larger weights amplify the
  !> steps' wiggles (hang 1025 x 1025 without bending: residuals 2-3 times
  !> the linear start's at steps 3-6, and Newton diverged at the sixth).
  pure logical function start_needs_linear(compare, nc, nc_prev)
    logical, intent(in) :: compare
    real(rp), intent(in) :: nc, nc_prev          !< ||F|| of this and the last polynomial start
    start_needs_linear = compare .or. .not. (nc <= 2.0_rp * nc_prev)
  end function start_needs_linear

  !> Both residuals evaluated (nc: polynomial, nl: linear): take_linear
  !> when the linear one is the smaller or the polynomial's is not finite;
  !> compare stays on unless the polynomial won by a factor 2.
  pure subroutine start_pick(nc, nl, take_linear, compare)
    real(rp), intent(in) :: nc, nl
    logical, intent(out) :: take_linear, compare
    take_linear = .not. (abs(nc) <= huge(nc)) .or. nl < nc
    compare = .true.
    if (.not. take_linear .and. 2.0_rp * nc < nl) compare = .false.
  end subroutine start_pick

end module start_predictor
