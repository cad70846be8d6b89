! SPDX-License-Identifier: BSD-2-Clause
!> Friction between layers of the cloth (issue 49 item 1;
!> docs/self-contact.md, "Friction between layers"): the lag of the
!> self-contact's active pairs and the friction work, for module
!> self_contact's hooks, over module self_friction's pair kernel.
!>
!> The lag is made at each accepted state (and at the run's start, or a
!> restart's) from the candidate pairs of the rank's list (self_broad's
!> OWN_TOUCH: every pair with an owned node) that are active there: each
!> keeps its 4 nodes, the coefficients of its nearest points, its normal
!> and its normal force. During the next step a lagged pair's friction acts
!> while the pair is active (gap < dhat) at the state evaluated: the
!> candidate list, whichever is current, holds every such pair and its
!> rows on every rank count (docs/self-contact.md, "The list"), so the
!> residual is the same function of the state on any number of ranks. (IPC
!> lets a lagged pair act whatever its gap now; a pair that leaves the
!> barrier within a step loses its friction here, a jump of at most mu lam,
!> small where the pair was near dhat at the lag: b'(dhat) = 0.) The lag
!> is a function of the accepted state alone, so a restart makes it again
!> from the restart's state; the friction work is checkpointed.
!>
!> The friction work is the trapezoid rule over each accepted step on the
!> power with the step's own lag at both ends (as the obstacles': module
!> contact_record), each pair counted on the rank owning its lowest node.
module self_lags
  use mpi
  use kinds, only: rp
  use contact, only: contact_params_t
  use self_broad, only: self_lattice_t, self_pairs_t, self_row_slots, self_pair_positions, self_pair_rest, &
                        self_pair_owner_row
  use self_barrier, only: self_blocks_t, self_blocks_add, self_pair_gap
  use self_friction, only: self_lag_t, self_pair_lag, self_pair_friction, self_pair_friction_power
  use work_arrays, only: grow
  implicit none
  private
  public :: self_lags_t, self_lags_setup, self_lags_on, self_lags_forces, self_lags_step, self_lags_work, &
            self_lags_restore, self_lags_count, self_lags_regrown

  !> The lag of a rank's active pairs and the run's friction work;
  !> written by this module's procedures alone.
  type :: self_lags_t
    private
    real(rp) :: mu = 0.0_rp                     !< &contact's self_mu [1]
    real(rp) :: eps_v = 0.0_rp                  !< friction_eps_v [length/time]
    integer :: n = 0                            !< lagged pairs on this rank
    integer, allocatable :: kind(:)             !< (n+) PAIR_PT or PAIR_EE
    integer, allocatable :: node(:, :)          !< (4, n+) the pair's global node numbers
    real(rp), allocatable :: w(:, :)            !< (4, n+) coefficients of the nearest points' difference [1]
    real(rp), allocatable :: nrm(:, :)          !< (3, n+) unit normal [1]
    real(rp), allocatable :: lam(:)             !< (n+) normal force [force]
    real(rp) :: work = 0.0_rp                   !< friction work since the start, over ranks [energy]
    real(rp) :: p_last = 0.0_rp                 !< power at the lag's state with its lag, over ranks [energy/time]
    real(rp) :: t_last = 0.0_rp                 !< the lag's time [time]
    logical :: have_last = .false.              !< a lag was made (the work integrates from it)
    integer :: regrown = 0                      !< reallocations of the lag's arrays
  end type self_lags_t

contains

  !> The coefficient mu and smoothing speed eps_v; no lag yet.
  subroutine self_lags_setup(lg, mu, eps_v)
    type(self_lags_t), intent(inout) :: lg
    real(rp), intent(in) :: mu, eps_v
    lg%mu = mu
    lg%eps_v = eps_v
    lg%n = 0
    lg%have_last = .false.
  end subroutine self_lags_setup

  !> Friction between layers is on (mu > 0).
  pure logical function self_lags_on(lg)
    type(self_lags_t), intent(in) :: lg
    self_lags_on = lg%mu > 0.0_rp
  end function self_lags_on

  !> Lagged pairs on this rank.
  pure integer function self_lags_count(lg)
    type(self_lags_t), intent(in) :: lg
    self_lags_count = lg%n
  end function self_lags_count

  !> Reallocations of the lag's arrays since set-up.
  pure integer function self_lags_regrown(lg)
    type(self_lags_t), intent(in) :: lg
    self_lags_regrown = lg%regrown
  end function self_lags_regrown

  !> The friction of every lagged pair active at the present rows' state
  !> x (1:3 positions, 4:6 velocities) added to f on the present rows;
  !> with blocks, its blocks df_a/dv_b of owned nodes a appended (the list
  !> is not emptied: the barrier's come first, or none). A pair with a row
  !> absent is not active (the list's rows hold every active pair).
  subroutine self_lags_forces(lg, sl, rows, x, cp, own_lo, own_hi, f, blocks)
    type(self_lags_t), intent(in) :: lg
    type(self_lattice_t), intent(in) :: sl
    integer, intent(in) :: rows(:)                   ! present global rows
    real(rp), intent(in) :: x(:, 0:, :)              ! (6, 0:nx-1, size(rows)) [length, length/time]
    type(contact_params_t), intent(in) :: cp
    integer, intent(in) :: own_lo, own_hi            ! this rank's rows
    real(rp), intent(inout) :: f(:, 0:, :)           ! (3, 0:nx-1, size(rows)) [force]
    type(self_blocks_t), intent(inout), optional :: blocks
    integer :: slot(0:sl%ny - 1), m, a, b, ja
    real(rp) :: fp(3, 4), kv(3, 3, 4, 4)
    if (lg%n == 0) return
    call self_row_slots(sl, rows, slot)
    do m = 1, lg%n
      if (.not. active_now(lg, m, sl, slot, x, cp)) cycle
      call self_pair_friction(lag_of(lg, m), lg%mu, lg%eps_v, &
                              self_pair_positions(sl, slot, x(4:6, :, :), lg%node(:, m)), fp, kv)
      do a = 1, 4
        associate (fa => f(1:3, mod(lg%node(a, m), sl%nx), slot(lg%node(a, m) / sl%nx)))
          fa = fa + fp(:, a)
        end associate
        if (.not. present(blocks)) cycle
        ja = lg%node(a, m) / sl%nx
        if (ja < own_lo .or. ja > own_hi) cycle
        do b = 1, 4
          call self_blocks_add(blocks, lg%node(a, m), lg%node(b, m), kv(:, :, a, b))
        end do
      end do
    end do
  end subroutine self_lags_forces

  !> The lag's step at an accepted state t (x: the present rows' positions
  !> and velocities; pairs: the candidate list, whose rows x holds): the
  !> friction work grows by the trapezoid rule with the old lag's power at
  !> both ends, then the lag is made again from the pairs active at x and
  !> its power there kept. A state seen already is left alone by the
  !> caller. Collective (the power's sums).
  subroutine self_lags_step(lg, sl, rows, x, pairs, cp, own_lo, own_hi, t, comm)
    type(self_lags_t), intent(inout) :: lg
    type(self_lattice_t), intent(in) :: sl
    integer, intent(in) :: rows(:)
    real(rp), intent(in) :: x(:, 0:, :)              ! (6, 0:nx-1, size(rows))
    type(self_pairs_t), intent(in) :: pairs
    type(contact_params_t), intent(in) :: cp
    integer, intent(in) :: own_lo, own_hi
    real(rp), intent(in) :: t                        ! [time]
    integer, intent(in) :: comm
    real(rp) :: p_end
    integer :: slot(0:sl%ny - 1)
    call self_row_slots(sl, rows, slot)
    p_end = power(lg, sl, slot, x, cp, own_lo, own_hi, comm)
    if (lg%have_last) lg%work = lg%work + 0.5_rp * (t - lg%t_last) * (lg%p_last + p_end)
    call make_lag(lg, sl, slot, x, pairs, cp)
    lg%p_last = power(lg, sl, slot, x, cp, own_lo, own_hi, comm)
    lg%t_last = t
    lg%have_last = .true.
  end subroutine self_lags_step

  !> The friction work since the start, over all ranks [energy].
  pure real(rp) function self_lags_work(lg)
    type(self_lags_t), intent(in) :: lg
    self_lags_work = lg%work
  end function self_lags_work

  !> A restart's friction work; the lag is made again at the restart's
  !> state (the accepted hook at the start).
  subroutine self_lags_restore(lg, work)
    type(self_lags_t), intent(inout) :: lg
    real(rp), intent(in) :: work
    lg%work = work
    lg%have_last = .false.
    lg%n = 0
  end subroutine self_lags_restore

  !> The lag of the pairs active at x (made from scratch).
  subroutine make_lag(lg, sl, slot, x, pairs, cp)
    type(self_lags_t), intent(inout) :: lg
    type(self_lattice_t), intent(in) :: sl
    integer, intent(in) :: slot(0:)
    real(rp), intent(in) :: x(:, 0:, :)
    type(self_pairs_t), intent(in) :: pairs
    type(contact_params_t), intent(in) :: cp
    type(self_lag_t) :: lag
    logical :: active
    integer :: m, nact, pass
    do pass = 1, 2
      nact = 0
      do m = 1, pairs%n
        call self_pair_lag(pairs%kind(m), self_pair_positions(sl, slot, x, pairs%node(:, m)), &
                           self_pair_rest(sl, pairs%node(:, m)), cp, lag, active)
        if (.not. active) cycle
        nact = nact + 1
        if (pass == 1) cycle
        lg%kind(nact) = pairs%kind(m)
        lg%node(:, nact) = pairs%node(:, m)
        lg%w(:, nact) = lag%w
        lg%nrm(:, nact) = lag%n
        lg%lam(nact) = lag%lam
      end do
      if (pass == 2) exit
      call grow(lg%kind, nact, lg%regrown)
      call grow(lg%node, 4, nact, lg%regrown)
      call grow(lg%w, 4, nact, lg%regrown)
      call grow(lg%nrm, 3, nact, lg%regrown)
      call grow(lg%lam, nact, lg%regrown)
    end do
    lg%n = nact
  end subroutine make_lag

  !> The friction power of the lag at x, each pair on the rank owning its
  !> lowest node, summed over the ranks [energy/time]. Collective.
  real(rp) function power(lg, sl, slot, x, cp, own_lo, own_hi, comm) result(p)
    type(self_lags_t), intent(in) :: lg
    type(self_lattice_t), intent(in) :: sl
    integer, intent(in) :: slot(0:)
    real(rp), intent(in) :: x(:, 0:, :)
    type(contact_params_t), intent(in) :: cp
    integer, intent(in) :: own_lo, own_hi, comm
    real(rp) :: ploc
    integer :: m, j, mpierr
    ploc = 0.0_rp
    do m = 1, lg%n
      j = self_pair_owner_row(sl, lg%node(:, m))
      if (j < own_lo .or. j > own_hi) cycle
      if (.not. active_now(lg, m, sl, slot, x, cp)) cycle
      ploc = ploc + self_pair_friction_power(lag_of(lg, m), lg%mu, lg%eps_v, &
                                             self_pair_positions(sl, slot, x(4:6, :, :), lg%node(:, m)))
    end do
    call MPI_Allreduce(ploc, p, 1, MPI_DOUBLE_PRECISION, MPI_SUM, comm, mpierr)
  end function power

  !> Lagged pair m is active at x: its rows present and its gap below dhat.
  logical function active_now(lg, m, sl, slot, x, cp)
    type(self_lags_t), intent(in) :: lg
    integer, intent(in) :: m
    type(self_lattice_t), intent(in) :: sl
    integer, intent(in) :: slot(0:)
    real(rp), intent(in) :: x(:, 0:, :)
    type(contact_params_t), intent(in) :: cp
    active_now = all(slot(lg%node(:, m) / sl%nx) > 0)
    if (.not. active_now) return
    active_now = self_pair_gap(lg%kind(m), self_pair_positions(sl, slot, x, lg%node(:, m)), cp%thickness) < cp%dhat
  end function active_now

  !> Lagged pair m as the kernel's record.
  pure type(self_lag_t) function lag_of(lg, m) result(lag)
    type(self_lags_t), intent(in) :: lg
    integer, intent(in) :: m
    lag = self_lag_t(w=lg%w(:, m), n=lg%nrm(:, m), lam=lg%lam(m))
  end function lag_of

end module self_lags
