! SPDX-License-Identifier: BSD-2-Clause
!> The step guarantee of the cloth's self-contact (issue 49 item 3;
!> docs/self-contact.md), in two flavours to compare:
!>
!> (a) a global step limit: the smallest ACCD alpha (module contact_ccd,
!>     fraction s of each gap kept) over the candidate pairs of the update's
!>     paths (self_broad's self_candidates_swept with margin = xi); the whole
!>     update is scaled by alpha. Every gap stays > 0 on [0, alpha]; one
!>     close pair stalls the whole cloth.
!> (b) per-vertex bounds in the manner of Offset Geometric Contact (Chen et
!>     al. 2025): each node v may move at most b_v = gamma (d_v - xi), d_v
!>     the smallest distance of a pair with v among its 4 nodes, from the
!>     candidates within r (self_candidates with reach r), r where there is
!>     none; an update longer than b_v is shortened to b_v, node by node.
!>     Why it is safe: the nearest points of a pair move by at most the
!>     largest displacement of each side's nodes (convex combinations), so
!>     a pair's distance changes by at most 2 gamma (d - xi) along the
!>     straight path, and its gap stays >= (1 - 2 gamma) gap0 > 0 for
!>     gamma < 1/2; a pair beyond r starts with gap >= r - xi and closes
!>     by at most 2 gamma (r - xi). Only nodes with a near pair, or that move
!>     farther than gamma (r - xi), are cut; the update's direction changes.
!> Both leave out what the broad phase leaves out (pairs sharing a node and
!> pairs nearer than rest_reach at rest). Plain arrays, no PETSc, no MPI.
module self_step
  use kinds, only: rp
  use contact_ccd, only: accd_point_triangle, accd_edge_edge
  use self_broad, only: self_lattice_t, self_pairs_t, PAIR_PT, self_row_slots, self_pair_positions, &
                        self_pair_distance2
  implicit none
  private
  public :: self_alpha_ccd, self_vertex_dmin, self_vertex_bounds, self_clamp, OGC_GAMMA
  public :: self_path_sums, self_path_far

  !> OGC's fraction of the distance a node may move (< 1/2; the gap keeps 1 - 2 gamma).
  real(rp), parameter :: OGC_GAMMA = 0.4_rp

contains

  !> (a): the smallest ACCD alpha in [0, 1] over the pairs for the paths x -> x + dx (pairs:
  !> self_candidates_swept with margin xi), keeping at least the fraction s of each gap.
  function self_alpha_ccd(lat, rows, x, dx, pairs, xi, s) result(alpha)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)                 ! present global rows
    real(rp), intent(in) :: x(:, 0:, :)            ! (3, 0:nx-1, size(rows)) start [length]
    real(rp), intent(in) :: dx(:, 0:, :)           ! (3, 0:nx-1, size(rows)) update [length]
    type(self_pairs_t), intent(in) :: pairs
    real(rp), intent(in) :: xi                     ! distance of zero gap [length]
    real(rp), intent(in) :: s                      ! fraction of each gap kept, e.g. ACCD_S [1]
    real(rp) :: alpha
    integer :: slot(0:lat%ny - 1)
    real(rp) :: xp(3, 4), dxp(3, 4)
    integer :: m

    call self_row_slots(lat, rows, slot)
    alpha = 1.0_rp
    do m = 1, pairs%n
      xp = self_pair_positions(lat, slot, x, pairs%node(:, m))
      dxp = self_pair_positions(lat, slot, dx, pairs%node(:, m))
      if (pairs%kind(m) == PAIR_PT) then
        alpha = min(alpha, accd_point_triangle(xp, dxp, xi, s, alpha))
      else
        alpha = min(alpha, accd_edge_edge(xp, dxp, xi, s, alpha))
      end if
      if (alpha <= 0.0_rp) return
    end do
  end function self_alpha_ccd

  !> (b), first part: dmin(i, r) <- min(dmin, the distance of each pair with node (i, rows(r))).
  !> Start from dmin = the broad phase's reach r (pairs: self_candidates with reach r).
  subroutine self_vertex_dmin(lat, rows, x, pairs, dmin)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    real(rp), intent(in) :: x(:, 0:, :)            ! (3, 0:nx-1, size(rows)) [length]
    type(self_pairs_t), intent(in) :: pairs
    real(rp), intent(inout) :: dmin(0:, :)         ! (0:nx-1, size(rows)) [length]
    integer :: slot(0:lat%ny - 1)
    real(rp) :: d
    integer :: m, k, g

    call self_row_slots(lat, rows, slot)
    do m = 1, pairs%n
      d = sqrt(self_pair_distance2(pairs%kind(m), self_pair_positions(lat, slot, x, pairs%node(:, m))))
      do k = 1, 4
        g = pairs%node(k, m)
        dmin(mod(g, lat%nx), slot(g / lat%nx)) = min(dmin(mod(g, lat%nx), slot(g / lat%nx)), d)
      end do
    end do
  end subroutine self_vertex_dmin

  !> (b), second part: the bounds b = gamma max(dmin - xi, 0) [length].
  pure subroutine self_vertex_bounds(dmin, xi, gamma, b)
    real(rp), intent(in) :: dmin(:, :)             ! [length]
    real(rp), intent(in) :: xi                     ! [length]
    real(rp), intent(in) :: gamma                  ! < 1/2, e.g. OGC_GAMMA [1]
    real(rp), intent(out) :: b(:, :)               ! [length]

    b = gamma * max(dmin - xi, 0.0_rp)
  end subroutine self_vertex_bounds

  !> (b), last part: each node's update longer than its bound shortened to it (direction
  !> kept); nclamped: the nodes cut.
  pure subroutine self_clamp(dx, b, nclamped)
    real(rp), intent(inout) :: dx(:, :, :)         ! (3, nx, nrows) [length]
    real(rp), intent(in) :: b(:, :)                ! (nx, nrows) [length]
    integer, intent(out) :: nclamped
    real(rp) :: l
    integer :: i, r

    nclamped = 0
    do r = 1, size(dx, 3)
      do i = 1, size(dx, 2)
        l = norm2(dx(1:3, i, r))
        if (l > b(i, r)) then
          nclamped = nclamped + 1
          if (l > 0.0_rp) dx(1:3, i, r) = dx(1:3, i, r) * (b(i, r) / l)
        end if
      end do
    end do
  end subroutine self_clamp

  !> The Verlet list's test (module self_contact's relative_move), the local sums over the
  !> rows of xd: d_i = p_i - x_list_i, p_i = xd(1:3) + alpha xd(4:6) (a point of the update's
  !> path); sums(1:3) of d_i, (4:6) of dx_list_i, (7) of d_i . dx_list_i, (8) of |dx_list_i|^2
  !> (the least-squares tau of d against dx_list and the mean translation, once summed over ranks).
  pure function self_path_sums(xd, alpha, x_list, dx_list) result(sums)
    real(rp), intent(in) :: xd(:, 0:, :)           ! (6, 0:nx-1, nrows) positions, update [length]
    real(rp), intent(in) :: alpha                  ! [1]
    real(rp), intent(in) :: x_list(:, 0:, :)       ! (3, 0:nx-1, nrows) the list's positions [length]
    real(rp), intent(in) :: dx_list(:, 0:, :)      ! (3, 0:nx-1, nrows) and its paths [length]
    real(rp) :: sums(8)                            ! [length] (1:6), [length^2] (7:8)
    real(rp) :: d(3)
    integer :: i, j
    sums = 0.0_rp
    do j = 1, size(xd, 3)
      do i = 0, size(xd, 2) - 1
        d = xd(1:3, i, j) + alpha * xd(4:6, i, j) - x_list(:, i, j)
        sums(1:3) = sums(1:3) + d
        sums(4:6) = sums(4:6) + dx_list(:, i, j)
        sums(7) = sums(7) + dot_product(d, dx_list(:, i, j))
        sums(8) = sums(8) + dot_product(dx_list(:, i, j), dx_list(:, i, j))
      end do
    end do
  end function self_path_sums

  !> The test's local part 2: the largest |p_i - (x_list_i + tau dx_list_i) - shift| over the
  !> rows of xd (shift: the mean translation).
  pure function self_path_far(xd, alpha, x_list, dx_list, tau, shift) result(far)
    real(rp), intent(in) :: xd(:, 0:, :)           ! (6, 0:nx-1, nrows) positions, update [length]
    real(rp), intent(in) :: alpha                  ! [1]
    real(rp), intent(in) :: x_list(:, 0:, :)       ! (3, 0:nx-1, nrows) [length]
    real(rp), intent(in) :: dx_list(:, 0:, :)      ! (3, 0:nx-1, nrows) [length]
    real(rp), intent(in) :: tau                    ! [1]
    real(rp), intent(in) :: shift(3)               ! [length]
    real(rp) :: far                                ! [length]
    real(rp) :: d(3)
    integer :: i, j
    far = 0.0_rp
    do j = 1, size(xd, 3)
      do i = 0, size(xd, 2) - 1
        d = xd(1:3, i, j) + alpha * xd(4:6, i, j) - x_list(:, i, j) - tau * dx_list(:, i, j)
        far = max(far, norm2(d - shift))
      end do
    end do
  end function self_path_far

end module self_step
