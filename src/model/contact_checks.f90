! SPDX-License-Identifier: BSD-2-Clause
!> The contact model's refusals of a scene it cannot start from (issue 47
!> item 7; docs/contact.md, "Bad input"): nodes of a state inside an
!> obstacle or within its contact_thickness (the initial state, a
!> restart's checkpoint), and prescribed nodes' paths that enter one.
!> Each is collective and ends in one line, the same on every rank,
!> naming the first such obstacle, the nodes' count and the first node.
module contact_checks
  use mpi
  use kinds, only: rp
  use lattice, only: lattice_t
  use constraints, only: constraint_set_t, constraint_count, constraint_node, constraint_path, constraint_base, &
                         constraint_keyframes, PATH_KEYFRAMES
  use contact, only: obstacle_t, signed_distance, time_of_impact_moving
  use obstacle_set, only: obstacle_set_t, obstacle_set_count, obstacle_set_poses, obstacle_set_pair, &
                          obstacle_set_key_times, obstacle_set_shape_name
  use strings, only: itoa, real_brief
  use small_sort, only: insertion_sort
  implicit none
  private
  public :: check_nodes, check_paths

contains

  !> No node of x(3, 0:nx-1, ys:ye) (every node, constrained or not) with a
  !> gap (distance - thickness) below floor to an obstacle of set at t:
  !> else, on every rank, one line naming the first such obstacle, its
  !> nodes' count and the first of them (lowest j, then i); head: the
  !> line's start, what: the state's name, hint: the line's end. Collective.
  subroutine check_nodes(set, thickness, floor, lat, t, x, comm, head, what, hint, ierr, errmsg)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: thickness, floor
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: t
    real(rp), intent(in) :: x(:, 0:, lat%ys:)
    integer, intent(in) :: comm
    character(*), intent(in) :: head, what, hint
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: i, j, k, n
    integer :: cnt(obstacle_set_count(set)), first(obstacle_set_count(set))
    real(rp) :: d, g(3), hd(3, 3)
    type(obstacle_t) :: obs(obstacle_set_count(set))
    n = obstacle_set_count(set)
    call obstacle_set_poses(set, t, obs)
    cnt = 0
    first = huge(1)
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        do k = 1, n
          call signed_distance(obs(k), x(1:3, i, j), d, g, hd)
          if (d - thickness >= floor) cycle
          cnt(k) = cnt(k) + 1
          first(k) = min(first(k), j * lat%nx + i)
        end do
      end do
    end do
    call refusal(set, lat, comm, cnt, first, .false., [(0.0_rp, k = 1, n)], head//what//': ', &
                 ' nodes lie inside obstacle ', ' or within its contact_thickness (a gap below '//real_brief(floor)// &
                 ', the acceptance floor 1e-6 contact_dhat), the first node ', hint, ierr, errmsg)
  end subroutine check_nodes

  !> No prescribed node's path (each owned constrained node of cs, pinned
  !> or on the keyframes, from t = 0 to t_stop) enters an obstacle or
  !> comes within its thickness (plus floor): the node and the obstacles
  !> move linearly between the union of their keyframe times, where
  !> time_of_impact_moving is exact. Else, on every rank, one line naming
  !> the first such obstacle, the nodes' count, the first node and when it
  !> enters. Collective.
  subroutine check_paths(set, thickness, floor, lat, cs, t_stop, comm, ierr, errmsg)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: thickness, floor
    type(lattice_t), intent(in) :: lat
    type(constraint_set_t), intent(in) :: cs
    real(rp), intent(in) :: t_stop
    integer, intent(in) :: comm
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: c, i, j, k, q, nk, node
    integer :: cnt(obstacle_set_count(set)), first(obstacle_set_count(set))
    real(rp) :: t_first(obstacle_set_count(set)), xa(3), xb(3), d(3), a, ta
    real(rp), allocatable :: kt(:), koff(:, :), tev(:)
    type(obstacle_t) :: o0, o1
    logical :: keyed
    call constraint_keyframes(cs, nk, kt, koff)
    cnt = 0
    first = huge(1)
    t_first = huge(1.0_rp)
    tev = event_times(set, kt(1:nk), t_stop)
    do c = 1, constraint_count(cs)
      call constraint_node(cs, c, i, j)
      node = j * lat%nx + i
      keyed = constraint_path(cs, c) == PATH_KEYFRAMES .and. nk > 0
      do k = 1, obstacle_set_count(set)
        do q = 1, size(tev) - 1
          ta = tev(q)
          xa = constraint_base(cs, c)
          xb = xa
          if (keyed) then
            xa = xa + path_offset(kt(1:nk), koff(:, 1:nk), tev(q))
            xb = xb + path_offset(kt(1:nk), koff(:, 1:nk), tev(q + 1))
          end if
          call obstacle_set_pair(set, k, tev(q), tev(q + 1), o0, o1, d)
          a = time_of_impact_moving(o0, thickness + floor, xa, xb - xa, d)
          if (a >= 1.0_rp) cycle
          cnt(k) = cnt(k) + 1
          if (node < first(k)) then
            first(k) = node
            t_first(k) = ta + a * (tev(q + 1) - ta)
          end if
          exit
        end do
      end do
    end do
    call refusal(set, lat, comm, cnt, first, .true., t_first, 'input: &contact: ', &
                 ' prescribed nodes'' paths (pinned or on keyframes) enter obstacle ', &
                 ' or come within its contact_thickness, the first node ', &
                 ': change the keyframes, the constraints or the obstacle', ierr, errmsg)
  end subroutine check_paths

  !> The times from 0 to t_stop at which a prescribed node's keyframe
  !> segment (kt) or an obstacle's ends, in order, without repeats.
  function event_times(set, kt, t_stop) result(tev)
    type(obstacle_set_t), intent(in) :: set
    real(rp), intent(in) :: kt(:), t_stop
    real(rp), allocatable :: tev(:)
    real(rp), allocatable :: ts(:)
    integer :: k, a, n
    ts = [0.0_rp, t_stop, kt]
    do k = 1, obstacle_set_count(set)
      ts = [ts, obstacle_set_key_times(set, k)]
    end do
    ts = pack(ts, ts >= 0.0_rp .and. ts <= t_stop)
    call insertion_sort(ts)     ! a few dozen times
    n = 0
    allocate(tev(size(ts)))
    do a = 1, size(ts)
      if (n > 0) then
        if (ts(a) == tev(n)) cycle
      end if
      n = n + 1
      tev(n) = ts(a)
    end do
    tev = tev(1:n)
  end function event_times

  !> The offset of the keyframe path (kt, koff) at t: linear between the
  !> keyframes, the first one's before and the last one's after (module
  !> constraints' constraint_target).
  pure function path_offset(kt, koff, t) result(off)
    real(rp), intent(in) :: kt(:), koff(:, :), t
    real(rp) :: off(3)
    integer :: m, n
    n = size(kt)
    if (t <= kt(1)) then
      off = koff(:, 1)
    else if (t >= kt(n)) then
      off = koff(:, n)
    else
      m = 1
      do while (kt(m + 1) <= t)
        m = m + 1
      end do
      off = koff(:, m) + (t - kt(m)) * (koff(:, m + 1) - koff(:, m)) / (kt(m + 1) - kt(m))
    end if
  end function path_offset

  !> The refusal of check_nodes and check_paths: cnt(k) nodes of this rank
  !> at obstacle k, the first of them (j nx + i) and, when timed, when
  !> (t_first(k)). The counts summed, the firsts' minimum over the ranks;
  !> the first obstacle with nodes named in one line: head, count, what1,
  !> obstacle, what2, node (i, j), [at t = ...], tail. ierr = 0 when there
  !> is none. Collective.
  subroutine refusal(set, lat, comm, cnt, first, timed, t_first, head, what1, what2, tail, ierr, errmsg)
    type(obstacle_set_t), intent(in) :: set
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: comm, cnt(:), first(:)
    logical, intent(in) :: timed
    real(rp), intent(in) :: t_first(:)
    character(*), intent(in) :: head, what1, what2, tail
    integer, intent(out) :: ierr
    character(*), intent(out) :: errmsg
    integer :: gcnt(size(cnt)), gfirst(size(cnt)), k, mpierr
    real(rp) :: tl(size(cnt)), tg(size(cnt))
    ierr = 0
    errmsg = ''
    call MPI_Allreduce(cnt, gcnt, size(cnt), MPI_INTEGER, MPI_SUM, comm, mpierr)
    call MPI_Allreduce(first, gfirst, size(cnt), MPI_INTEGER, MPI_MIN, comm, mpierr)
    if (all(gcnt == 0)) return
    tg = 0.0_rp
    if (timed) then
      tl = merge(t_first, huge(1.0_rp), first == gfirst .and. cnt > 0)
      call MPI_Allreduce(tl, tg, size(cnt), MPI_DOUBLE_PRECISION, MPI_MIN, comm, mpierr)
    end if
    do k = 1, size(cnt)
      if (gcnt(k) == 0) cycle
      ierr = 1
      errmsg = head//itoa(gcnt(k))//what1//itoa(k)//' ('''//obstacle_set_shape_name(set, k)//''')'//what2// &
               '('//itoa(mod(gfirst(k), lat%nx))//', '//itoa(gfirst(k) / lat%nx)//')'
      if (timed) errmsg = trim(errmsg)//' at t = '//real_brief(tg(k))
      errmsg = trim(errmsg)//tail
      return
    end do
  end subroutine refusal

end module contact_checks
