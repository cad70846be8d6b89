! SPDX-License-Identifier: BSD-2-Clause
!> The barrier of the cloth's self-contact pairs (issue 49 item 2;
!> docs/self-contact.md): for a point-triangle or edge-edge pair of the
!> broad phase (module self_broad), the energy kappa k b(gap) with gap =
!> distance - xi (xi = cp%thickness: the distance at which two pieces of
!> cloth touch), contact's IPC barrier b and, for edge-edge pairs, IPC's
!> mollifier k with eps_x = EE_MOLLIFY_REL |a_rest|^2 |b_rest|^2 (the edges'
!> rest lengths), exactly as contact_faces' pairs against an obstacle but
!> with all four points unknowns: the force on each of the 4 nodes and the
!> 16 blocks df_a/dx_b, exact or minus the positive semidefinite part of the
!> pair's Hessian (point-triangle: in its range, rank <= 5; edge-edge: the
!> whole 12 x 12, the mollifier's terms leave that range).
!>
!> For the solver, the pairs of a rank's list give forces on the present
!> rows and a list of pair blocks (node a, node b, df_a/dx_b) by global
!> node number: the nodes of a pair are not stencil neighbours in general.
!> With self_broad's OWN_LOWEST the fetched rows' forces go back to their
!> owners (module self_exchange's self_exchange_add); with OWN_TOUCH each
!> rank keeps its own rows' forces and blocks (those with node a owned,
!> each one entry (a, b) of pair_blocks' list) and drops the rest.
!> The energy and the count of active pairs are those of the pairs whose
!> lowest node's row is in own_lo..own_hi, so that sums over ranks count
!> each pair once under either rule. Forces depend on positions only:
!> each pair's forces sum to zero and each block row of a pair sums to zero.
!> Plain arrays, no PETSc, no MPI; the block list grows as needed.
module self_barrier
  use kinds, only: rp
  use contact, only: contact_params_t
  use contact_faces, only: pair_barrier, psd_project_in_span, EE_MOLLIFY_REL
  use contact_primitives, only: point_triangle_distance, edge_edge_distance, edge_edge_mollifier, &
                                point_triangle_range, psd_project
  use self_broad, only: self_lattice_t, self_pairs_t, PAIR_PT, PAIR_EE, self_row_slots, self_pair_positions, &
                        self_pair_rest, self_pair_owner_row
  implicit none
  private
  public :: self_blocks_t, self_pair_barrier, self_barrier_forces, self_pair_gap, self_blocks_reserve, self_blocks_regrown, &
            self_blocks_add

  !> Pair blocks: k(:, :, m) = df_a/dx_b [force/length] of nodes a(m), b(m) (global numbers).
  !> The same (a, b) may come several times (one entry a pair): the solver sums them.
  type :: self_blocks_t
    integer :: n = 0
    integer, allocatable :: a(:), b(:)
    real(rp), allocatable :: k(:, :, :)   !< (3, 3, n+)
    integer :: regrown = 0                !< times the arrays were reallocated larger (self_blocks_regrown)
  end type self_blocks_t

contains

  !> Gap (distance - xi) of a pair at positions xp [length].
  pure real(rp) function self_pair_gap(kind, xp, xi) result(gap)
    integer, intent(in) :: kind
    real(rp), intent(in) :: xp(3, 4), xi
    real(rp) :: d2, g(12), h(12, 12)
    integer :: ty

    if (kind == PAIR_PT) then
      call point_triangle_distance(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), d2, g, h, ty)
    else
      call edge_edge_distance(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), d2, g, h, ty)
    end if
    gap = sqrt(d2) - xi
  end function self_pair_gap

  !> One pair's barrier: energy e, forces f(:, a) on its nodes a = 1..4 (PT: p, t0, t1, t2;
  !> EE: a0, a1, b0, b1) and blocks kx(:, :, a, b) = df_a/dx_b (project: minus the PSD part
  !> of the pair's Hessian); active when gap < dhat. gap <= 0: e = huge, f = kx = 0
  !> (the caller must refuse the state).
  pure subroutine self_pair_barrier(kind, xp, xr, cp, project, e, f, kx, active)
    integer, intent(in) :: kind                      ! PAIR_PT or PAIR_EE
    real(rp), intent(in) :: xp(3, 4)                 ! positions [length]
    real(rp), intent(in) :: xr(3, 4)                 ! rest positions (the mollifier's scale) [length]
    type(contact_params_t), intent(in) :: cp         ! thickness (= xi), dhat, kappa
    logical, intent(in) :: project
    real(rp), intent(out) :: e                       ! [energy]
    real(rp), intent(out) :: f(3, 4)                 ! [force]
    real(rp), intent(out) :: kx(3, 3, 4, 4)          ! [force/length]
    logical, intent(out) :: active
    real(rp) :: d2, g(12), h(12, 12), mk, gk(12), hk(12, 12), ge(12), he(12, 12), eps_x, vr(12, 5)
    integer :: ty, a, b, nv

    e = 0.0_rp
    f = 0.0_rp
    kx = 0.0_rp
    mk = 1.0_rp
    gk = 0.0_rp
    hk = 0.0_rp
    if (kind == PAIR_PT) then
      call point_triangle_distance(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), d2, g, h, ty)
    else
      call edge_edge_distance(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), d2, g, h, ty)
    end if
    active = sqrt(d2) - cp%thickness < cp%dhat
    if (.not. active) return
    if (kind == PAIR_EE) then
      eps_x = EE_MOLLIFY_REL * sum((xr(:, 2) - xr(:, 1))**2) * sum((xr(:, 4) - xr(:, 3))**2)
      call edge_edge_mollifier(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), eps_x, mk, gk, hk)
    end if
    call pair_barrier(cp, cp%thickness, d2, g, h, mk, gk, hk, e, ge, he)
    if (e >= huge(1.0_rp)) return
    if (project) then
      if (kind == PAIR_PT) then
        call point_triangle_range(xp(:, 1), xp(:, 2), xp(:, 3), xp(:, 4), vr, nv)
        call psd_project_in_span(he, vr(:, 1:nv))
      else
        call psd_project(he)
      end if
    end if
    do b = 1, 4
      f(:, b) = -ge(3 * b - 2:3 * b)
      do a = 1, 4
        kx(:, :, a, b) = -he(3 * a - 2:3 * a, 3 * b - 2:3 * b)
      end do
    end do
  end subroutine self_pair_barrier

  !> The barrier of every pair of the list at positions x of the present rows: adds the
  !> forces to f (same layout as x), returns the energy e of the pairs owned by their
  !> lowest node (huge where a gap is <= 0), the blocks of the active pairs (16 a pair;
  !> the list is emptied first) and the number nact of active pairs owned so.
  subroutine self_barrier_forces(lat, rows, x, pairs, own_lo, own_hi, cp, project, e, f, blocks, nact)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)                   ! present global rows
    real(rp), intent(in) :: x(:, 0:, :)              ! (3, 0:nx-1, size(rows)) [length]
    type(self_pairs_t), intent(in) :: pairs
    integer, intent(in) :: own_lo, own_hi            ! this rank's rows
    type(contact_params_t), intent(in) :: cp
    logical, intent(in) :: project
    real(rp), intent(out) :: e                       ! [energy]
    real(rp), intent(inout) :: f(:, 0:, :)           ! (3, 0:nx-1, size(rows)) [force]
    type(self_blocks_t), intent(inout) :: blocks
    integer, intent(out) :: nact
    integer :: slot(0:lat%ny - 1)
    real(rp) :: ep, fp(3, 4), kp(3, 3, 4, 4)
    logical :: active
    integer :: m, a, b, j, node(4)

    call self_row_slots(lat, rows, slot)
    e = 0.0_rp
    nact = 0
    blocks%n = 0
    do m = 1, pairs%n
      node = pairs%node(:, m)
      call self_pair_barrier(pairs%kind(m), self_pair_positions(lat, slot, x, node), self_pair_rest(lat, node), &
                             cp, project, ep, fp, kp, active)
      if (.not. active) cycle
      j = self_pair_owner_row(lat, node)
      if (j >= own_lo .and. j <= own_hi) then
        nact = nact + 1
        if (ep >= huge(1.0_rp) .or. e >= huge(1.0_rp)) then
          e = huge(1.0_rp)
        else
          e = e + ep
        end if
      end if
      do a = 1, 4
        associate (fa => f(1:3, mod(node(a), lat%nx), slot(node(a) / lat%nx)))
          fa = fa + fp(:, a)
        end associate
        do b = 1, 4
          call add_block(blocks, node(a), node(b), kp(:, :, a, b))
        end do
      end do
    end do
  end subroutine self_barrier_forces

  !> Room for at least n blocks (a size estimate made at set-up: the list then grows only
  !> past it).
  pure subroutine self_blocks_reserve(blocks, n)
    type(self_blocks_t), intent(inout) :: blocks
    integer, intent(in) :: n

    call grow_blocks(blocks, n)
  end subroutine self_blocks_reserve

  !> Times the list's arrays were reallocated larger since it was made.
  pure integer function self_blocks_regrown(blocks) result(n)
    type(self_blocks_t), intent(in) :: blocks

    n = blocks%regrown
  end function self_blocks_regrown

  !> Append the block k of nodes a, b (global numbers); the arrays grow (doubled) when full.
  pure subroutine self_blocks_add(blocks, a, b, k)
    type(self_blocks_t), intent(inout) :: blocks
    integer, intent(in) :: a, b
    real(rp), intent(in) :: k(3, 3)

    call add_block(blocks, a, b, k)
  end subroutine self_blocks_add

  pure subroutine add_block(blocks, a, b, k)
    type(self_blocks_t), intent(inout) :: blocks
    integer, intent(in) :: a, b
    real(rp), intent(in) :: k(3, 3)

    if (.not. allocated(blocks%a)) then
      call grow_blocks(blocks, 256)
    else if (blocks%n == size(blocks%a)) then
      call grow_blocks(blocks, 2 * blocks%n)
    end if
    blocks%n = blocks%n + 1
    blocks%a(blocks%n) = a
    blocks%b(blocks%n) = b
    blocks%k(:, :, blocks%n) = k
  end subroutine add_block

  !> The list's arrays at least cap long, its blocks kept.
  pure subroutine grow_blocks(blocks, cap)
    type(self_blocks_t), intent(inout) :: blocks
    integer, intent(in) :: cap
    integer, allocatable :: a2(:), b2(:)
    real(rp), allocatable :: k2(:, :, :)

    if (allocated(blocks%a)) then
      if (size(blocks%a) >= cap) return
    end if
    allocate(a2(cap), b2(cap), k2(3, 3, cap))
    if (blocks%n > 0) then
      a2(1:blocks%n) = blocks%a(1:blocks%n)
      b2(1:blocks%n) = blocks%b(1:blocks%n)
      k2(:, :, 1:blocks%n) = blocks%k(:, :, 1:blocks%n)
    end if
    call move_alloc(a2, blocks%a)
    call move_alloc(b2, blocks%b)
    call move_alloc(k2, blocks%k)
    blocks%regrown = blocks%regrown + 1
  end subroutine grow_blocks

end module self_barrier
