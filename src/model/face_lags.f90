! SPDX-License-Identifier: BSD-2-Clause
!> Friction of the cloth's triangles and edges against the obstacles
!> (module face_contact), lagged as the node contact's (IPC): at each
!> accepted state every pair in the barrier's reach keeps the weights of
!> its nearest cloth point on the element's nodes, its normal and its
!> normal force (kernel contact_face_friction's face_lag_t); during the
!> next step friction is implicit in the velocities with that fixed
!> magnitude. This is the list of those lags on a rank's strip (the
!> elements that touch an owned row, as face_elements takes them), its
!> forces, velocity blocks and dissipated power. The components are
!> private: only this module's procedures write them. The arrays are kept
!> from one state to the next (grown when a state has more pairs).
module face_lags
  use kinds, only: rp
  use lattice, only: lattice_t
  use contact, only: obstacle_t, contact_params_t
  use contact_faces, only: SPLIT_MAIN, near_obstacle, quad_triangles, quad_diagonal
  use contact_face_friction, only: face_lag_t, triangle_lag, edge_lag, pair_friction, pair_friction_power, pair_turn
  use node_blocks, only: node_blocks_t, node_blocks_add_pair
  use face_elements, only: WALK_BLOCKS
  implicit none
  private
  public :: face_lag_list_t, lags_clear, lags_take, lags_walk, lags_power, lags_count, lags_with_friction, lags_turn

  !> The lagged pairs of a strip.
  type :: face_lag_list_t
    private
    integer :: n = 0                          !< pairs in the list
    integer, allocatable :: obs(:)            !< (capacity) the pair's obstacle
    integer, allocatable :: node(:, :, :)     !< (2, 3, capacity) (i, j) of its cloth nodes (an edge: 2, the third unused)
    integer, allocatable :: nn(:)             !< (capacity) 3 (triangle) or 2 (edge)
    logical, allocatable :: anchor_owned(:)   !< (capacity) its element's anchor row is owned (counted here once)
    type(face_lag_t), allocatable :: lag(:)   !< (capacity) weights, normal, normal force
  end type face_lag_list_t

  real(rp), parameter :: ZERO33(3, 3) = 0.0_rp

contains

  !> No pairs (before the first state).
  subroutine lags_clear(lst)
    type(face_lag_list_t), intent(inout) :: lst
    lst%n = 0
  end subroutine lags_clear

  !> Pairs in the list.
  pure integer function lags_count(lst)
    type(face_lag_list_t), intent(in) :: lst
    lags_count = lst%n
  end function lags_count

  !> Appends the lags of every pair within reach of obstacle k (pose o)
  !> of the elements touching the owned rows at the ghosted state u: each
  !> quad's two triangles and diagonal, the x- and y-links (rest lengths
  !> ax, ay). Call lags_clear first, then once per obstacle.
  subroutine lags_take(lst, k, o, cp, lat, u)
    type(face_lag_list_t), intent(inout) :: lst
    integer, intent(in) :: k
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer :: i, j, a, t, m, nl, tri(3, 2), ca, cb, ni(4), nj(4)
    real(rp) :: xq(3, 4)
    type(face_lag_t) :: lt(12)
    logical :: own
    call quad_triangles(SPLIT_MAIN, tri)
    call quad_diagonal(SPLIT_MAIN, ca, cb)
    do j = max(0, lat%ys - 1), min(lat%ny - 2, lat%ye)
      own = j >= lat%ys
      do i = 0, lat%nx - 2
        ni = [i, i + 1, i, i + 1]
        nj = [j, j, j + 1, j + 1]
        do a = 1, 4
          xq(:, a) = u(0:2, ni(a), nj(a))
        end do
        if (.not. near_obstacle(o, cp%dhat + cp%thickness, xq)) cycle
        do t = 1, 2
          call triangle_lag(o, cp, xq(:, tri(:, t)), lt(1:8), nl)
          do m = 1, nl
            call push(lst, k, 3, ni(tri(:, t)), nj(tri(:, t)), own, lt(m))
          end do
        end do
        call edge_lag(o, cp, xq(:, [ca, cb]), hypot(lat%ax, lat%ay), lt, nl)
        do m = 1, nl
          call push(lst, k, 2, [ni(ca), ni(cb), 0], [nj(ca), nj(cb), 0], own, lt(m))
        end do
      end do
    end do
    ! the links: x-links of the owned rows, y-links anchored at ys-1..ye
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 2
        call take_edge(i, j, i + 1, j, lat%ax, .true.)
      end do
    end do
    do j = max(0, lat%ys - 1), min(lat%ny - 2, lat%ye)
      do i = 0, lat%nx - 1
        call take_edge(i, j, i, j + 1, lat%ay, j >= lat%ys)
      end do
    end do

  contains

    subroutine take_edge(ia, ja, ib, jb, rest, owned)
      integer, intent(in) :: ia, ja, ib, jb
      real(rp), intent(in) :: rest
      logical, intent(in) :: owned
      real(rp) :: xe(3, 2)
      integer :: q, nq
      xe(:, 1) = u(0:2, ia, ja)
      xe(:, 2) = u(0:2, ib, jb)
      if (.not. near_obstacle(o, cp%dhat + cp%thickness, xe)) return
      call edge_lag(o, cp, xe, rest, lt, nq)
      do q = 1, nq
        call push(lst, k, 2, [ia, ib, 0], [ja, jb, 0], owned, lt(q))
      end do
    end subroutine take_edge

  end subroutine lags_take

  subroutine push(lst, k, nn, ni, nj, own, lag)
    type(face_lag_list_t), intent(inout) :: lst
    integer, intent(in) :: k, nn, ni(3), nj(3)
    logical, intent(in) :: own
    type(face_lag_t), intent(in) :: lag
    if (.not. allocated(lst%obs)) allocate(lst%obs(64), lst%node(2, 3, 64), lst%nn(64), lst%anchor_owned(64), lst%lag(64))
    if (lst%n == size(lst%obs)) call grow(lst, 2 * lst%n)
    lst%n = lst%n + 1
    lst%obs(lst%n) = k
    lst%nn(lst%n) = nn
    lst%node(1, :, lst%n) = ni
    lst%node(2, :, lst%n) = nj
    lst%anchor_owned(lst%n) = own
    lst%lag(lst%n) = lag
  end subroutine push

  subroutine grow(lst, m)
    type(face_lag_list_t), intent(inout) :: lst
    integer, intent(in) :: m
    integer, allocatable :: o(:), nd(:, :, :), nn(:)
    logical, allocatable :: ow(:)
    type(face_lag_t), allocatable :: lg(:)
    allocate(o(m), nd(2, 3, m), nn(m), ow(m), lg(m))
    o(1:lst%n) = lst%obs(1:lst%n)
    nd(:, :, 1:lst%n) = lst%node(:, :, 1:lst%n)
    nn(1:lst%n) = lst%nn(1:lst%n)
    ow(1:lst%n) = lst%anchor_owned(1:lst%n)
    lg(1:lst%n) = lst%lag(1:lst%n)
    call move_alloc(o, lst%obs)
    call move_alloc(nd, lst%node)
    call move_alloc(nn, lst%nn)
    call move_alloc(ow, lst%anchor_owned)
    call move_alloc(lg, lst%lag)
  end subroutine grow

  !> The walk over the lagged pairs at the ghosted velocities of u, the
  !> obstacles obs (their poses at the state's time: velocity and mu), by
  !> mode (face_elements' WALK_*): WALK_FORCES, f(3, 0:nx-1, ys:ye) += the
  !> friction forces on the free owned nodes, of obstacle only's pairs
  !> alone (only = 0: every obstacle's; nodal untouched); WALK_BLOCKS,
  !> their velocity blocks df/dv into nodal on each free owned node's row,
  !> its own and those to the pair's other nodes, every obstacle's (only
  !> and f untouched).
  subroutine lags_walk(mode, lst, obs, cp, lat, fixed, u, only, f, nodal)
    integer, intent(in) :: mode
    type(face_lag_list_t), intent(in) :: lst
    type(obstacle_t), intent(in) :: obs(:)
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer, intent(in) :: only
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    type(node_blocks_t), intent(inout) :: nodal
    integer :: m, a, b, nn, i, j
    real(rp) :: v(3, 3), fp(3, 3), kv(3, 3, 3, 3)
    logical :: blocks
    blocks = mode == WALK_BLOCKS
    do m = 1, lst%n
      if (.not. blocks .and. only /= 0 .and. lst%obs(m) /= only) cycle
      if (obs(lst%obs(m))%mu <= 0.0_rp) cycle
      nn = lst%nn(m)
      do a = 1, nn
        v(:, a) = u(3:5, lst%node(1, a, m), lst%node(2, a, m))
      end do
      call pair_friction(obs(lst%obs(m)), cp, lst%lag(m), v(:, 1:nn), fp(:, 1:nn), kv(:, :, 1:nn, 1:nn))
      do a = 1, nn
        i = lst%node(1, a, m)
        j = lst%node(2, a, m)
        if (j < lat%ys .or. j > lat%ye) cycle
        if (fixed(i, j)) cycle
        if (.not. blocks) then
          f(:, i, j) = f(:, i, j) + fp(:, a)
          cycle
        end if
        do b = 1, nn
          call node_blocks_add_pair(nodal, i, j, lst%node(1, b, m) - i, lst%node(2, b, m) - j, ZERO33, kv(:, :, a, b))
        end do
      end do
    end do
  end subroutine lags_walk

  !> The power friction dissipates at the ghosted velocities of u (each
  !> pair once over the ranks: by its element's anchor row) [energy/time].
  real(rp) function lags_power(lst, obs, cp, lat, u) result(p)
    type(face_lag_list_t), intent(in) :: lst
    type(obstacle_t), intent(in) :: obs(:)
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    integer :: m, a, nn
    real(rp) :: v(3, 3)
    p = 0.0_rp
    do m = 1, lst%n
      if (.not. lst%anchor_owned(m) .or. obs(lst%obs(m))%mu <= 0.0_rp) cycle
      nn = lst%nn(m)
      do a = 1, nn
        v(:, a) = u(3:5, lst%node(1, a, m), lst%node(2, a, m))
      end do
      p = p + pair_friction_power(obs(lst%obs(m)), cp, lst%lag(m), v(:, 1:nn))
    end do
  end function lags_power

  !> Pairs in the list whose obstacle has friction (mu > 0).
  pure integer function lags_with_friction(lst, obs) result(n)
    type(face_lag_list_t), intent(in) :: lst
    type(obstacle_t), intent(in) :: obs(:)
    integer :: m
    n = 0
    do m = 1, lst%n
      if (obs(lst%obs(m))%mu > 0.0_rp) n = n + 1
    end do
  end function lags_with_friction

  !> The Newton update's guard where a pair's slip turns: for each lagged
  !> pair whose slip the update vd(4:6, ...) of the velocities vd(1:3, ...)
  !> turns through the sticking band (kernel contact_face_friction's
  !> pair_turn), fac of each of its free nodes becomes at most the
  !> fraction of the update where the slip is least.
  !> vd, free and fac span the rows ys-1..ye+1 (the list's elements touch
  !> the owned rows); fac is 1 where no pair turns (set by the caller).
  subroutine lags_turn(lst, obs, cp, lat, vd, free, fac)
    type(face_lag_list_t), intent(in) :: lst
    type(obstacle_t), intent(in) :: obs(:)
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: vd(:, 0:, lat%ys - 1:)       ! (6, 0:nx-1, ys-1:ye+1) velocities, their update [length/time]
    logical, intent(in) :: free(0:, lat%ys - 1:)         ! (0:nx-1, ys-1:ye+1) the node is not constrained
    real(rp), intent(inout) :: fac(0:, lat%ys - 1:)      ! (0:nx-1, ys-1:ye+1) each node's fraction [1]
    integer :: m, a, nn, i, j
    real(rp) :: v(3, 3), dv(3, 3), alpha
    do m = 1, lst%n
      if (obs(lst%obs(m))%mu <= 0.0_rp) cycle
      nn = lst%nn(m)
      do a = 1, nn
        v(:, a) = vd(1:3, lst%node(1, a, m), lst%node(2, a, m))
        dv(:, a) = vd(4:6, lst%node(1, a, m), lst%node(2, a, m))
      end do
      alpha = pair_turn(obs(lst%obs(m)), cp, lst%lag(m), v(:, 1:nn), dv(:, 1:nn))
      if (alpha >= 1.0_rp) cycle
      do a = 1, nn
        i = lst%node(1, a, m)
        j = lst%node(2, a, m)
        if (free(i, j)) fac(i, j) = min(fac(i, j), alpha)
      end do
    end do
  end subroutine lags_turn

end module face_lags
