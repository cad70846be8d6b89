! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the Newton start's arithmetic and safeguard (kernel
!> start_predictor):
!>  - the polynomial start of order p is exact for data that are a
!>    polynomial of order p in t, and off by (p+1)! c dt^(p+1) for
!>    c t^(p+1) (the Lagrange remainder), in exact binary arithmetic;
!>  - the line through two unequally spaced states is exact for linear data;
!>  - the spacing count stops at the first gap that is not dt;
!>  - the safeguard compares while the polynomial has not won by a factor
!>    2, again when its residual doubles, and takes the linear start when
!>    it is the smaller or the polynomial's residual is not finite.
program test_start_predictor
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
  use kinds, only: rp
  use start_predictor, only: START_KEPT, start_spaced, start_weights, start_linear_weights, start_needs_linear, start_pick
  use check, only: check_true, check_close, check_report
  implicit none
  real(rp), parameter :: TN = 1.5_rp, DT = 0.25_rp
  real(rp) :: c(0:4), ts(START_KEPT), w2(2), nan, inf, lead
  integer :: p, k
  logical :: take_linear, compare
  character(len=8) :: tag

  call check_true(START_KEPT == 4, 'four states kept (the cubic)')
  ! q(t) = c0 + c1 t + ... of order p, at t_n, t_n - dt, ...; the start
  ! evaluates it at t_n + dt.
  c = [3.0_rp, -2.0_rp, 5.0_rp, -1.0_rp, 2.0_rp]
  do p = 1, 3
    write(tag, '(a,i0)') ' p = ', p
    call check_true(size(start_weights(p)) == p + 1, 'weights of'//tag//': p + 1 of them')
    call check_close(sum(start_weights(p)), 1.0_rp, 0.0_rp, 0.0_rp, 'weights of'//tag//' sum to 1 (constants)')
    call check_close(extrapolate(p, p), q(p, TN + DT), 0.0_rp, 0.0_rp, 'order'//tag//' exact on its own order')
    if (p > 1) call check_close(extrapolate(p, p - 1), q(p - 1, TN + DT), 0.0_rp, 0.0_rp, 'order'//tag//' exact on lower order')
    ! one order higher: q_{p+1} - P = c_{p+1} (t - t_n)...(t - t_{n-p}) at t_n + dt
    lead = c(p + 1) * DT**(p + 1) * real(product([(k, k = 1, p + 1)]), rp)
    call check_close(q(p + 1, TN + DT) - extrapolate(p, p + 1), lead, 0.0_rp, 0.0_rp, &
                     'order'//tag//' misses c (p+1)! dt^(p+1) one order higher')
  end do

  ! The line through (t0, x0), (t1, x1) at t0 + h, spacing 0.75 and h 0.125.
  w2 = start_linear_weights(2.0_rp, 1.25_rp, 0.125_rp)
  call check_close(w2(1) * lin(2.0_rp) + w2(2) * lin(1.25_rp), lin(2.125_rp), 1.0e-15_rp, 0.0_rp, 'line through unequal spacing')
  call check_close(sum(w2), 1.0_rp, 1.0e-15_rp, 0.0_rp, 'line weights sum to 1')

  ! Spacing: equally spaced states counted from the newest.
  ts = [1.0_rp, 0.75_rp, 0.5_rp, 0.25_rp]
  call check_true(start_spaced(ts, 4, 0.25_rp) == 4, 'four equally spaced')
  call check_true(start_spaced(ts, 3, 0.25_rp) == 3, 'only the kept ones count')
  call check_true(start_spaced(ts, 1, 0.25_rp) == 1, 'one state kept')
  call check_true(start_spaced(ts, 4, 0.1_rp) == 1, 'another dt: the newest alone')
  ts = [1.0_rp, 0.75_rp, 0.6875_rp, 0.4375_rp]
  call check_true(start_spaced(ts, 4, 0.25_rp) == 2, 'a retried step (dt/4) ends the spacing')
  ts = [1.0_rp, 0.75_rp + 1.0e-13_rp, 0.5_rp, 0.25_rp - 1.0e-13_rp]
  call check_true(start_spaced(ts, 4, 0.25_rp) == 4, 'spacing to round-off of sums of steps')

  ! The safeguard.
  nan = ieee_value(1.0_rp, ieee_quiet_nan)
  inf = ieee_value(1.0_rp, ieee_positive_inf)
  call check_true(start_needs_linear(.true., 1.0_rp, 10.0_rp), 'compare while the polynomial has not won')
  call check_true(.not. start_needs_linear(.false., 2.0_rp, 1.0_rp), 'no comparison at twice the last residual')
  call check_true(start_needs_linear(.false., 2.5_rp, 1.0_rp), 'compare when the residual more than doubles')
  call check_true(start_needs_linear(.false., nan, 1.0_rp), 'compare when the residual is NaN')
  call start_pick(2.0_rp, 1.0_rp, take_linear, compare)
  call check_true(take_linear .and. compare, 'the linear start when its residual is the smaller')
  call start_pick(1.0_rp, 3.0_rp, take_linear, compare)
  call check_true(.not. take_linear .and. .not. compare, 'the polynomial won by more than 2: stop comparing')
  call start_pick(1.0_rp, 2.0_rp, take_linear, compare)
  call check_true(.not. take_linear .and. compare, 'the polynomial won by exactly 2: go on comparing')
  call start_pick(nan, 1.0_rp, take_linear, compare)
  call check_true(take_linear .and. compare, 'NaN polynomial residual: the linear start')
  call start_pick(inf, inf, take_linear, compare)
  call check_true(take_linear .and. compare, 'infinite polynomial residual: the linear start')

  call check_report()

contains

  !> q of order m (coefficients c(0:m)) at t, by Horner.
  real(rp) function q(m, t)
    integer, intent(in) :: m
    real(rp), intent(in) :: t
    integer :: j
    q = c(m)
    do j = m - 1, 0, -1
      q = q * t + c(j)
    end do
  end function q

  !> The start of order p on the data q of order m at t_n, t_n - dt, ...
  real(rp) function extrapolate(p, m)
    integer, intent(in) :: p, m
    real(rp) :: w(p + 1)
    integer :: j
    w = start_weights(p)
    extrapolate = 0.0_rp
    do j = 0, p
      extrapolate = extrapolate + w(j + 1) * q(m, TN - j * DT)
    end do
  end function extrapolate

  real(rp) function lin(t)
    real(rp), intent(in) :: t
    lin = 0.3_rp - 1.7_rp * t
  end function lin

end program test_start_predictor
