! SPDX-License-Identifier: BSD-2-Clause
!> The step guarantee of the cloth's self-contact (module self_contact's
!> hooks step_limit and limit_nodes; docs/self-contact.md, "The step
!> guarantee: two flavours"), chosen by &contact's self_step:
!>   'accd' (a)  every Newton update and predictor scaled by the smallest
!>               ACCD alpha over the pairs its paths may bring within xi,
!>               the minimum over the ranks (self_step_limit);
!>   'ogc'  (b)  each free node's update shortened to its own bound
!>               gamma (d_v - xi), d_v its nearest pair's distance
!>               (self_limit_nodes), so that each pair keeps 1 - 2 gamma of
!>               its gap (module self_step); no fraction of the whole.
!> Both keep the Verlet list holding at the update's end (the next
!> residual's state), made again from the update's paths where it does not.
submodule (self_contact) self_contact_step
  use self_step, only: self_vertex_dmin, OGC_GAMMA
  implicit none

contains

  !> Flavour (a): the update x -> x + dx scaled by the smallest ACCD alpha
  !> (a tenth of each gap kept) over the pairs its paths may bring within
  !> xi, the minimum over the ranks. Where every node's path stays within
  !> skin/2 of the list's positions less the mean translation
  !> (relative_move; both ends: the path is a segment) the
  !> list holds every such pair (they were within xi + skin of each other
  !> at its positions) and its pairs serve; else the list is made again
  !> from the update's paths (list_over_path) and serves, its positions
  !> then those of the limited end x + alpha dx.
  !> PM_INFEASIBLE where no fraction is allowed. With 'ogc' the bounds
  !> of self_limit_nodes, which ran on this update just before, keep every
  !> gap and the list holds at both of its ends: alpha = 1, unless a
  !> constrained node (whose update is prescribed, never shortened) moved
  !> past its bound; then (a)'s alpha over the shortened update. Collective.
  module subroutine self_step_limit(this, lat, fixed, t0, t1, x0, x, dx, comm, alpha, status)
    class(self_contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x0(0:, 0:, lat%ys:), x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    real(rp), intent(out) :: alpha
    integer, intent(out) :: status
    real(rp) :: a, gfar
    integer :: ierr, mpierr, n
    alpha = 1.0_rp
    status = PM_FEASIBLE
    if (this%g%ogc .and. .not. this%g%accd_needed) return
    n = this%nrows
    associate (xd => this%w%xd(:, :, lat%ys:lat%ye))
    xd(1:3, :, :) = x(0:2, :, lat%ys:lat%ye)
    xd(4:6, :, :) = dx(0:2, :, lat%ys:lat%ye)
    gfar = max(relative_move(this, lat, comm, xd, 0.0_rp), relative_move(this, lat, comm, xd, 1.0_rp))
    ierr = 0
    if (gfar > 0.5_rp * this%skin) then
      call list_over_path(this, lat, comm, x, dx, ierr)
      n = this%nrows
      xd(1:3, :, :) = x(0:2, :, lat%ys:lat%ye)
      xd(4:6, :, :) = dx(0:2, :, lat%ys:lat%ye)
    end if
    alpha = 0.0_rp
    if (ierr == 0) then
      call self_exchange_gather(this%w%xch, xd, this%w%xall(:, :, 1:n), ierr)
      a = self_alpha_ccd(this%sl, this%rows(1:n), this%w%xall(1:3, :, 1:n), this%w%xall(4:6, :, 1:n), this%pairs, &
                         this%cp%thickness, ACCD_S)
      call MPI_Allreduce(a, alpha, 1, MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    end if
    ! a list made from the paths holds around any point of them (relative_move's tau)
    if (gfar > 0.5_rp * this%skin) then
      this%x_list = xd(1:3, :, :)
      this%dx_list = LOOKAHEAD * xd(4:6, :, :)
    end if
    end associate
    status = merge(PM_INFEASIBLE, PM_FEASIBLE, alpha <= 0.0_rp .or. ierr /= 0)
    ! an update clamped node by node (self_limit_nodes) is counted there, once
    if (alpha < 1.0_rp .and. .not. this%g%clamped_now) this%g%limited = this%g%limited + 1
  end subroutine self_step_limit

  !> The list made again for an update x -> x + dx that leaves it, from
  !> the update's paths: the swept candidates (OWN_TOUCH) within the
  !> reach dhat + xi + skin anywhere along them (ACCD's rate bound, a
  !> pair's own relative motion: a flat sheet's lattice neighbours moving
  !> together stay out), with a swept plan of rows. A pair left out stays
  !> beyond that reach at every point of the paths, so the list serves the
  !> CCD of this update and, made at any point x + alpha dx of it
  !> (x_list, set by the caller), the states within skin/2 of that: one
  !> broad phase where the swept candidates and a list at the limited
  !> candidate took two. Collective.
  subroutine list_over_path(this, lat, comm, x, dx, ierr)
    class(self_contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    integer, intent(out) :: ierr
    integer :: n
    associate (w => this%w, xd => this%w%xd)
    ! positions and updates of the owned rows and the rows below and above [length]
    call with_neighbour_rows(this, lat, comm, x, dx, xd)
    xd(4:6, :, :) = LOOKAHEAD * xd(4:6, :, :)
    call self_exchange_plan_swept(w%xch, comm, lat%nx, lat%ny, lat%ys, lat%ye, xd(1:3, :, :), xd(4:6, :, :), &
                                  this%rest_reach + this%skin, PATCH_ROWS, ierr)
    if (ierr /= 0) return
    call take_plan_rows(this, lat%nx, n)
    call self_exchange_gather(w%xch, xd(:, :, lat%ys:lat%ye), w%xall(:, :, 1:n), ierr)
    if (ierr /= 0) return
    call self_candidates_swept(this%sl, this%rows(1:n), w%xall(1:3, :, 1:n), w%xall(4:6, :, 1:n), lat%ys, lat%ye, &
                               OWN_TOUCH, this%rest_reach + this%skin, this%rest_reach, this%pairs)
    this%searches = this%searches + 1
    this%rebuilt = this%rebuilt + 1
    end associate
  end subroutine list_over_path

  !> Flavour (b), OGC's per-vertex bounds: at x (the update's start, where
  !> the list is made to hold: every pair within dhat + xi of a node is in
  !> it), each present node's nearest pair distance d_v (self_vertex_dmin,
  !> dhat + xi where none is nearer: a pair outside the list is at least
  !> that far), and each free owned node's update dx (positions and
  !> velocities alike: the node's own Newton step scaled) longer than
  !> gamma (d_v - xi) shortened to it. OWN_TOUCH: every pair with an owned
  !> node is in this rank's list, so the owner's d_v is the minimum over
  !> all ranks without an exchange. A constrained node's update is kept
  !> (it is prescribed); where one passes its bound, accd_needed makes the
  !> step limit that follows take (a)'s alpha too. Then the list is made to
  !> hold at the shortened end. changed: some node was shortened, on any
  !> rank. Nothing with 'accd'. Collective.
  module subroutine self_limit_nodes(this, lat, fixed, t0, t1, x, dx, comm, changed)
    class(self_contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: t0, t1
    real(rp), intent(in) :: x(0:, 0:, lat%ys:)
    real(rp), intent(inout) :: dx(0:, 0:, lat%ys:)
    integer, intent(in) :: comm
    logical, intent(out) :: changed
    integer :: counts(2), gcounts(2), ierr, n, i, j, mpierr, slot(0:lat%ny - 1)
    real(rp) :: b, l
    changed = .false.
    this%g%accd_needed = .false.
    this%g%clamped_now = .false.
    if (.not. this%g%ogc) return
    call list_holds_at(this, lat, comm, x, dx, 0.0_rp, ierr)
    n = this%nrows
    if (ierr == 0) call self_exchange_gather(this%w%xch, x(0:2, :, lat%ys:lat%ye), this%w%xall(1:3, :, 1:n), ierr)
    counts = 0
    if (ierr /= 0) counts(2) = 1
    associate (dmin => this%w%dmin(:, 1:n))
    if (ierr == 0) then
      dmin = this%rest_reach
      call self_vertex_dmin(this%sl, this%rows(1:n), this%w%xall(1:3, :, 1:n), this%pairs, dmin)
      call self_row_slots(this%sl, this%rows(1:n), slot)
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          b = OGC_GAMMA * max(dmin(i + 1, slot(j)) - this%cp%thickness, 0.0_rp)
          l = norm2(dx(0:2, i, j))
          if (l <= b) cycle
          if (fixed(i, j)) then
            counts(2) = counts(2) + 1
          else
            counts(1) = counts(1) + 1
            dx(:, i, j) = dx(:, i, j) * (b / l)
          end if
        end do
      end do
    end if
    end associate
    call MPI_Allreduce(counts, gcounts, 2, MPI_INTEGER, MPI_SUM, comm, mpierr)
    changed = gcounts(1) > 0
    this%g%clamped_now = changed
    this%g%accd_needed = gcounts(2) > 0
    if (changed) then
      this%g%limited = this%g%limited + 1
      this%g%clamped = this%g%clamped + gcounts(1)
    end if
    ! the next residual's state, x + dx, within the list's reach
    call list_holds_at(this, lat, comm, x, dx, 1.0_rp, ierr)
    if (ierr /= 0) this%g%accd_needed = .true.
  end subroutine self_limit_nodes

  !> The list made to hold at x + alpha dx (alpha 0 or 1): kept where every
  !> node is within skin/2 of its paths there (relative_move), else made
  !> again from the update's paths (list_over_path), which holds along
  !> them. Collective.
  subroutine list_holds_at(this, lat, comm, x, dx, alpha, ierr)
    class(self_contact_model_t), intent(inout) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    real(rp), intent(in) :: alpha                ! [1]
    integer, intent(out) :: ierr
    ierr = 0
    associate (xd => this%w%xd(:, :, lat%ys:lat%ye))
    xd(1:3, :, :) = x(0:2, :, lat%ys:lat%ye)
    xd(4:6, :, :) = dx(0:2, :, lat%ys:lat%ye)
    if (relative_move(this, lat, comm, xd, alpha) <= 0.5_rp * this%skin) return
    call list_over_path(this, lat, comm, x, dx, ierr)
    xd(1:3, :, :) = x(0:2, :, lat%ys:lat%ye)
    xd(4:6, :, :) = dx(0:2, :, lat%ys:lat%ye)
    this%x_list = xd(1:3, :, :)
    this%dx_list = LOOKAHEAD * xd(4:6, :, :)
    end associate
  end subroutine list_holds_at


  !> How far the nodes have moved from the list's paths apart from a
  !> common translation: the largest |d_i - T| over all nodes, d_i =
  !> p_i - (x_list_i + tau dx_list_i), p_i = xd(1:3) + alpha xd(4:6) (a
  !> point on the update's path), tau in [0, 1] the least-squares fit of
  !> p - x_list to dx_list over the lattice (0 for a static list) and T the
  !> mean of d. Every pair outside the list was beyond its reach at every
  !> common tau of the list's paths, and a pair's distance depends on
  !> differences of positions, so it has changed by at most twice this
  !> from there; along the update's path d - T is linear, so its ends
  !> bound it: the Verlet list's test. (The largest |d_i| itself made a
  !> falling sheet's skin, and its list, grow with its speed.) Collective.
  module function relative_move(this, lat, comm, xd, alpha) result(gfar)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: xd(:, 0:, :)         ! (6, 0:nx-1, ys:ye) positions, update [length]
    real(rp), intent(in) :: alpha                ! [1]
    real(rp) :: gfar                             ! [length]
    real(rp) :: sums(8), gsums(8), far, tau
    integer :: mpierr
    sums = self_path_sums(xd, alpha, this%x_list, this%dx_list)
    call MPI_Allreduce(sums, gsums, 8, MPI_DOUBLE_PRECISION, MPI_SUM, comm, mpierr)
    tau = 0.0_rp
    if (gsums(8) > 0.0_rp) tau = min(max(gsums(7) / gsums(8), 0.0_rp), 1.0_rp)
    gsums(1:3) = (gsums(1:3) - tau * gsums(4:6)) / real(lat%nx * lat%ny, rp)
    far = self_path_far(xd, alpha, this%x_list, this%dx_list, tau, gsums(1:3))
    call MPI_Allreduce(far, gfar, 1, MPI_DOUBLE_PRECISION, MPI_MAX, comm, mpierr)
  end function relative_move

  !> The rows the exchange plan just made present (own and fetched): their
  !> list kept in the model and the work arrays grown to hold them.
  module subroutine take_plan_rows(this, nx, n)
    class(self_contact_model_t), intent(inout) :: this
    integer, intent(in) :: nx
    integer, intent(out) :: n                    !< rows present on this rank (own and fetched)
    associate (w => this%w)
    n = self_exchange_nrows(w%xch)
    this%nrows = n
    call grow(this%rows, n, w%regrown)
    call self_exchange_rows_copy(w%xch, this%rows)
    call grow(w%xall, 6, nx, n, w%regrown)
    call grow(w%fall, 3, nx, n, w%regrown)
    if (this%g%ogc) call grow(w%dmin, nx, n, w%regrown)
    end associate
  end subroutine take_plan_rows

  !> The positions and updates (x, dx: 0:2 of (0:5, 0:nx-1, ys:ye)) of
  !> the owned rows and of the rows ys-1 and ye+1 from the ranks below and
  !> above, into xd(1:3, ...) and xd(4:6, ...). Collective.
  subroutine with_neighbour_rows(this, lat, comm, x, dx, xd)
    class(self_contact_model_t), intent(in) :: this
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm
    real(rp), intent(in) :: x(0:, 0:, lat%ys:), dx(0:, 0:, lat%ys:)
    real(rp), intent(out) :: xd(:, 0:, max(lat%ys - 1, 0):)
    real(rp) :: snd(6, 0:lat%nx - 1), rcv(6, 0:lat%nx - 1)
    integer :: mpierr
    xd(1:3, :, lat%ys:lat%ye) = x(0:2, :, lat%ys:lat%ye)
    xd(4:6, :, lat%ys:lat%ye) = dx(0:2, :, lat%ys:lat%ye)
    ! row ys down (the row above of the rank below), row ye up
    snd = xd(:, :, lat%ys)
    call MPI_Sendrecv(snd, size(snd), MPI_DOUBLE_PRECISION, this%rank_down, 4903, rcv, size(rcv), &
                      MPI_DOUBLE_PRECISION, this%rank_up, 4903, comm, MPI_STATUS_IGNORE, mpierr)
    if (this%rank_up /= MPI_PROC_NULL) xd(:, :, lat%ye + 1) = rcv
    snd = xd(:, :, lat%ye)
    call MPI_Sendrecv(snd, size(snd), MPI_DOUBLE_PRECISION, this%rank_up, 4904, rcv, size(rcv), &
                      MPI_DOUBLE_PRECISION, this%rank_down, 4904, comm, MPI_STATUS_IGNORE, mpierr)
    if (this%rank_down /= MPI_PROC_NULL) xd(:, :, lat%ys - 1) = rcv
  end subroutine with_neighbour_rows

end submodule self_contact_step
