! SPDX-License-Identifier: BSD-2-Clause
!> The cloth's triangles and edges against one rigid obstacle, over a
!> rank's strip (issue 47 item 3; docs/design.md, "Contact", faces and
!> edges): the loops over the lattice's elements that call the kernels
!> contact_faces and contact_ccd, for module face_contact's hooks. No
!> MPI, no PETSc, no allocation.
!>
!> The elements: quad (i, j) (corners (i,j), (i+1,j), (i,j+1), (i+1,j+1),
!> split along its main diagonal into two triangles; its diagonal edge
!> is its own), the x-link (i,j)-(i+1,j) and the y-link (i,j)-(i,j+1);
!> quads and y-links are anchored at their lower row j, x-links at their
!> row. Each element's nodes are within one lattice offset of each other,
!> so its blocks fit S's 9-point stencil (node_blocks_add_pair).
!>
!> Which rank takes an element: the forces and blocks of every element
!> that touches an owned row (quads and y-links anchored at ys-1..ye,
!> x-links at ys..ye: the ghosted state holds their nodes), each rank
!> keeping what falls on its own free nodes, as the links' forces are
!> taken; the gaps, energies, counts and the step limit by the rank that
!> owns the element's anchor row, its lowest node's (every element once
!> over the ranks; the step limit's row ye+1 comes from the rank above).
module face_elements
  use kinds, only: rp
  use lattice, only: lattice_t
  use contact, only: obstacle_t, contact_params_t, SHAPE_PLANE
  use contact_faces, only: SPLIT_MAIN, near_obstacle, contact_quad, contact_edge, quad_triangles, quad_diagonal, &
                           triangle_gap, edge_gap, triangle_correction, edge_correction
  use contact_ccd, only: ccd_triangle, ccd_edge
  use node_blocks, only: node_blocks_t, node_blocks_add_pair
  implicit none
  private
  public :: has_features, elements_walk, elements_gap, elements_ccd, elements_mark, elements_correct

  integer, parameter :: EL_QUAD = 1, EL_XLINK = 2, EL_YLINK = 3
  !> elements_walk's modes (face_lags' lags_walk takes the same)
  integer, parameter, public :: WALK_FORCES = 1, WALK_BLOCKS = 2, WALK_STATS = 3
  real(rp), parameter :: ZERO33(3, 3) = 0.0_rp
  !> The fraction of a quad's gap to an obstacle's core that quad_swept's
  !> ACCD keeps (face_contact's SWEPT_S for the step's path).
  real(rp), parameter :: SWEPT_KEEP = 1.0e-6_rp

contains

  !> Whether the obstacle has features that a cloth triangle or edge can
  !> meet between its nodes: every shape but a plane (a triangle's nearest
  !> point to a plane is a vertex, which the node contact holds).
  pure logical function has_features(o)
    type(obstacle_t), intent(in) :: o
    has_features = o%shape /= SHAPE_PLANE
  end function has_features

  !> Rows j0..j1 and columns 0..i1 of the elements of one kind, with quads
  !> and y-links anchored at jq0..jq1 and x-links at jx0..jx1, clipped to
  !> the lattice.
  pure subroutine kind_range(lat, kind, jq0, jq1, jx0, jx1, j0, j1, i1)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: kind, jq0, jq1, jx0, jx1
    integer, intent(out) :: j0, j1, i1
    select case (kind)
    case (EL_XLINK)
      j0 = max(0, jx0)
      j1 = min(lat%ny - 1, jx1)
      i1 = lat%nx - 2
    case (EL_YLINK)
      j0 = max(0, jq0)
      j1 = min(lat%ny - 2, jq1)
      i1 = lat%nx - 1
    case default
      j0 = max(0, jq0)
      j1 = min(lat%ny - 2, jq1)
      i1 = lat%nx - 2
    end select
  end subroutine kind_range

  !> The nodes (ni(a), nj(a)), a = 1..nn, of element (i, j) of a kind.
  pure subroutine element_nodes(kind, i, j, ni, nj, nn)
    integer, intent(in) :: kind, i, j
    integer, intent(out) :: ni(4), nj(4), nn
    select case (kind)
    case (EL_XLINK)
      ni = [i, i + 1, 0, 0]
      nj = [j, j, 0, 0]
      nn = 2
    case (EL_YLINK)
      ni = [i, i, 0, 0]
      nj = [j, j + 1, 0, 0]
      nn = 2
    case default
      ni = [i, i + 1, i, i + 1]
      nj = [j, j, j + 1, j + 1]
      nn = 4
    end select
  end subroutine element_nodes

  !> One element's barrier against o: energy e, forces f(:, a), blocks
  !> kx(:, :, a, b) = df_a/dx_b on its nn nodes at positions x(3, nn)
  !> (project: each pair's Hessian on the PSD cone), nact active pairs;
  !> e = huge where a pair has gap <= 0.
  pure subroutine element_barrier(o, cp, lat, kind, x, project, e, f, kx, nact)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: kind
    real(rp), intent(in) :: x(:, :)
    logical, intent(in) :: project
    real(rp), intent(out) :: e, f(3, 4), kx(3, 3, 4, 4)
    integer, intent(out) :: nact
    real(rp) :: f2(3, 2), k2(3, 3, 2, 2)
    f = 0.0_rp
    kx = 0.0_rp
    select case (kind)
    case (EL_QUAD)
      call contact_quad(o, cp, SPLIT_MAIN, x, hypot(lat%ax, lat%ay), project, e, f, kx, nact)
    case (EL_XLINK)
      call contact_edge(o, cp, x, lat%ax, project, e, f2, k2, nact)
      f(:, 1:2) = f2
      kx(:, :, 1:2, 1:2) = k2
    case default
      call contact_edge(o, cp, x, lat%ay, project, e, f2, k2, nact)
      f(:, 1:2) = f2
      kx(:, :, 1:2, 1:2) = k2
    end select
  end subroutine element_barrier

  !> The walk over the elements near o at the ghosted state u, by mode:
  !> WALK_FORCES, of the elements touching the owned rows,
  !> f(3, 0:nx-1, ys:ye) += their barrier forces on the free owned nodes
  !> and count += the elements with a pair at gap <= 0; WALK_BLOCKS, of
  !> the same elements, their blocks df/dx into nodal, on each free owned
  !> node's row its own block and those to the element's other nodes
  !> (stencil neighbours), each pair's Hessian projected on the PSD cone
  !> so that S stays positive definite whatever the shape's curvature
  !> (the residual, evaluated far more often, does not pay for blocks);
  !> WALK_STATS, of the elements anchored on the owned rows (each once
  !> over the ranks), count += the pairs within the barrier's reach and
  !> energy += their energy [energy]. What a mode does not name is left
  !> untouched.
  subroutine elements_walk(mode, o, cp, lat, fixed, u, f, nodal, count, energy)
    integer, intent(in) :: mode
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    real(rp), intent(in) :: u(0:, 0:, lat%gys:)
    real(rp), intent(inout) :: f(:, 0:, lat%ys:)
    type(node_blocks_t), intent(inout) :: nodal
    integer, intent(inout) :: count
    real(rp), intent(inout) :: energy
    integer :: kind, i, j, j0, j1, i1, a, b, nn, nact, ni(4), nj(4), jq0
    real(rp) :: x(3, 4), e, fe(3, 4), ke(3, 3, 4, 4)
    jq0 = merge(lat%ys, lat%ys - 1, mode == WALK_STATS)
    do kind = EL_QUAD, EL_YLINK
      call kind_range(lat, kind, jq0, lat%ye, lat%ys, lat%ye, j0, j1, i1)
      do j = j0, j1
        do i = 0, i1
          call element_nodes(kind, i, j, ni, nj, nn)
          do a = 1, nn
            x(:, a) = u(0:2, ni(a), nj(a))
          end do
          if (.not. near_obstacle(o, cp%dhat + cp%thickness, x(:, 1:nn))) cycle
          call element_barrier(o, cp, lat, kind, x(:, 1:nn), mode == WALK_BLOCKS, e, fe, ke, nact)
          if (nact == 0) cycle
          if (mode == WALK_STATS) then
            count = count + nact
            energy = energy + e
            cycle
          end if
          if (e >= huge(1.0_rp)) then
            if (mode == WALK_FORCES) count = count + 1
            cycle
          end if
          do a = 1, nn
            if (.not. owned_free(lat, fixed, ni(a), nj(a))) cycle
            if (mode == WALK_FORCES) then
              f(:, ni(a), nj(a)) = f(:, ni(a), nj(a)) + fe(:, a)
              cycle
            end if
            do b = 1, nn
              call node_blocks_add_pair(nodal, ni(a), nj(a), ni(b) - ni(a), nj(b) - nj(a), ke(:, :, a, b), ZERO33)
            end do
          end do
        end do
      end do
    end do
  end subroutine elements_walk

  !> The smallest gap (distance - radius - thickness) of the cloth's
  !> triangles, their edges and nodes included, to o over the quads
  !> anchored at rows jq0..jq1 of x(3, 0:nx-1, xlo:) (huge where none is
  !> within reach + thickness), only those with a node where only(0:nx-1,
  !> xlo:) holds if given [length].
  real(rp) function elements_gap(o, cp, lat, xlo, x, jq0, jq1, only) result(gmin)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: xlo, jq0, jq1
    real(rp), intent(in) :: x(:, 0:, xlo:)
    logical, intent(in), optional :: only(0:, xlo:)
    integer :: i, j, j0, j1, i1, a, nn, ni(4), nj(4), tri(3, 2), t
    real(rp) :: xq(3, 4)
    gmin = huge(1.0_rp)
    call quad_triangles(SPLIT_MAIN, tri)
    call kind_range(lat, EL_QUAD, jq0, jq1, jq0, jq1, j0, j1, i1)
    do j = j0, j1
      do i = 0, i1
        call element_nodes(EL_QUAD, i, j, ni, nj, nn)
        if (present(only)) then
          if (.not. any([(only(ni(a), nj(a)), a = 1, nn)])) cycle
        end if
        do a = 1, nn
          xq(:, a) = x(1:3, ni(a), nj(a))
        end do
        if (.not. near_obstacle(o, cp%dhat + cp%thickness, xq)) cycle
        do t = 1, 2
          gmin = min(gmin, triangle_gap(o, cp%thickness, xq(:, tri(:, t))))
        end do
      end do
    end do
  end function elements_gap

  !> The step limit of the elements anchored at rows ys..ye moving from
  !> x(3, 0:nx-1, ys:ye+1) by dx (the same rows; row ye+1 from the rank
  !> above) against o translating by dobs: the smallest ACCD fraction
  !> (contact_ccd; the fraction s of each pair's gap kept) over the quads'
  !> triangles and diagonals and the x- and y-links, 1 where none comes
  !> near [1].
  real(rp) function elements_ccd(o, thickness, lat, x, dx, dobs, s) result(alpha)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: thickness
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: x(:, 0:, lat%ys:), dx(:, 0:, lat%ys:)
    real(rp), intent(in) :: dobs(3), s
    integer :: kind, i, j, j0, j1, i1, a, nn, ni(4), nj(4), tri(3, 2), ca, cb, t
    real(rp) :: xq(3, 4), dq(3, 4), path(3, 8)
    alpha = 1.0_rp
    call quad_triangles(SPLIT_MAIN, tri)
    call quad_diagonal(SPLIT_MAIN, ca, cb)
    do kind = EL_QUAD, EL_YLINK
      call kind_range(lat, kind, lat%ys, lat%ye, lat%ys, lat%ye, j0, j1, i1)
      do j = j0, j1
        do i = 0, i1
          call element_nodes(kind, i, j, ni, nj, nn)
          do a = 1, nn
            xq(:, a) = x(:, ni(a), nj(a))
            dq(:, a) = dx(:, ni(a), nj(a))
            path(:, a) = xq(:, a)
            path(:, nn + a) = xq(:, a) + dq(:, a) - dobs
          end do
          if (.not. near_obstacle(o, thickness, path(:, 1:2 * nn))) cycle
          if (kind == EL_QUAD) then
            do t = 1, 2
              alpha = min(alpha, ccd_triangle(o, thickness, xq(:, tri(:, t)), dq(:, tri(:, t)), dobs, s))
            end do
            alpha = min(alpha, ccd_edge(o, thickness, xq(:, [ca, cb]), dq(:, [ca, cb]), dobs, s))
          else
            alpha = min(alpha, ccd_edge(o, thickness, xq(:, 1:2), dq(:, 1:2), dobs, s))
          end if
        end do
      end do
    end do
  end function elements_ccd

  !> The second-order correction c(3, 0:nx-1, xlo:) of the update dx at x (both (3, 0:nx-1,
  !> xlo:), rows ys-1..ye+1; free(0:nx-1, xlo:) the nodes the update moves) for the elements
  !> touching the owned rows (as WALK_FORCES takes them) against o: each node's largest
  !> correction over the pairs of its elements (kernel contact_faces' triangle_correction,
  !> edge_correction), kept where larger than c's own. Every element that touches an owned
  !> node is taken on its rank, so an owned node's correction is the same on any number of
  !> ranks [length].
  subroutine elements_correct(o, cp, lat, xlo, x, dx, free, c)
    type(obstacle_t), intent(in) :: o
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: xlo
    real(rp), intent(in) :: x(:, 0:, xlo:), dx(:, 0:, xlo:)
    logical, intent(in) :: free(0:, xlo:)
    real(rp), intent(inout) :: c(:, 0:, xlo:)
    integer :: kind, i, j, j0, j1, i1, a, nn, ni(4), nj(4), tri(3, 2), ca, cb, t
    real(rp) :: xq(3, 4), dq(3, 4), path(3, 8), v(3, 4), vt(3, 3), ve(3, 2)
    logical :: fq(4)
    call quad_triangles(SPLIT_MAIN, tri)
    call quad_diagonal(SPLIT_MAIN, ca, cb)
    do kind = EL_QUAD, EL_YLINK
      call kind_range(lat, kind, lat%ys - 1, lat%ye, lat%ys, lat%ye, j0, j1, i1)
      do j = j0, j1
        do i = 0, i1
          call element_nodes(kind, i, j, ni, nj, nn)
          do a = 1, nn
            xq(:, a) = x(:, ni(a), nj(a))
            dq(:, a) = dx(:, ni(a), nj(a))
            fq(a) = free(ni(a), nj(a))
            path(:, a) = xq(:, a)
            path(:, nn + a) = xq(:, a) + dq(:, a)
          end do
          if (.not. near_obstacle(o, cp%dhat + cp%thickness, path(:, 1:2 * nn))) cycle
          v = 0.0_rp
          if (kind == EL_QUAD) then
            do t = 1, 2
              vt = v(:, tri(:, t))
              call triangle_correction(o, cp, xq(:, tri(:, t)), dq(:, tri(:, t)), fq(tri(:, t)), vt)
              v(:, tri(:, t)) = vt
            end do
            ve = v(:, [ca, cb])
            call edge_correction(o, cp, xq(:, [ca, cb]), dq(:, [ca, cb]), fq([ca, cb]), ve)
            v(:, [ca, cb]) = ve
          else
            call edge_correction(o, cp, xq(:, 1:2), dq(:, 1:2), fq(1:2), v(:, 1:2))
          end if
          do a = 1, nn
            if (norm2(v(:, a)) > norm2(c(:, ni(a), nj(a)))) c(:, ni(a), nj(a)) = v(:, a)
          end do
        end do
      end do
    end do
  end subroutine elements_correct

  !> Marks (mark(i, j) = .true.) the owned nodes (rows ys..ye) of the
  !> quads anchored at rows jq0..jq1 of x0(3, 0:nx-1, xlo:) that an
  !> obstacle moving from o0 to o1 (by d) reaches: the quad's gap to o1
  !> below contact_dhat and below its gap to o0 (the obstacle approaches
  !> it), its gaps those of its triangles (edges and nodes included), or
  !> the obstacle's path passing through the quad (quad_swept, against the
  !> obstacle's core oc at t0, as the node contact's carried start,
  !> module obstacle_set): an obstacle that moves more than its size in a
  !> step, a capsule of radius 2 cm at 5 cm a step, is beyond the reach
  !> of the quads it passed through at t1. A quad that
  subroutine elements_mark(o0, o1, oc, d, cp, lat, xlo, x0, jq0, jq1, mark)
    type(obstacle_t), intent(in) :: o0, o1, oc
    real(rp), intent(in) :: d(3)              ! the obstacle's translation from o0 to o1 [length]
    type(contact_params_t), intent(in) :: cp
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: xlo, jq0, jq1
    real(rp), intent(in) :: x0(:, 0:, xlo:)
    logical, intent(inout) :: mark(0:, lat%ys:)
    integer :: i, j, j0, j1, i1, a, nn, ni(4), nj(4), tri(3, 2), t
    real(rp) :: xq(3, 4), g0, g1, path(3, 8)
    call quad_triangles(SPLIT_MAIN, tri)
    call kind_range(lat, EL_QUAD, jq0, jq1, jq0, jq1, j0, j1, i1)
    do j = j0, j1
      do i = 0, i1
        call element_nodes(EL_QUAD, i, j, ni, nj, nn)
        do a = 1, nn
          xq(:, a) = x0(1:3, ni(a), nj(a))
        end do
        path(:, 1:4) = xq
        path(:, 5:8) = xq - spread(d, 2, 4)
        if (.not. near_obstacle(o0, cp%dhat + cp%thickness, path)) cycle
        g0 = huge(1.0_rp)
        g1 = huge(1.0_rp)
        do t = 1, 2
          g0 = min(g0, triangle_gap(o0, cp%thickness, xq(:, tri(:, t))))
          g1 = min(g1, triangle_gap(o1, cp%thickness, xq(:, tri(:, t))))
        end do
        if ((g1 < cp%dhat .and. g1 < g0) .or. quad_swept(oc, xq, d)) then
          do a = 1, nn
            if (nj(a) >= lat%ys .and. nj(a) <= lat%ye) mark(ni(a), nj(a)) = .true.
          end do
        end if
      end do
    end do
  end subroutine elements_mark

  !> Whether quad xq(3, 4) at rest passes through the core oc of an
  !> obstacle that translates by d over the step: the ACCD of the motion
  !> relative to it stops short of the whole path for a triangle or a side
  !> or the diagonal of the quad (keeping SWEPT_KEEP of the gap: only a
  !> path into the core, or nearly, counts).
  pure logical function quad_swept(oc, xq, d) result(swept)
    type(obstacle_t), intent(in) :: oc
    real(rp), intent(in) :: xq(3, 4), d(3)
    integer, parameter :: sides(2, 5) = reshape([1, 2, 2, 4, 4, 3, 3, 1, 1, 4], [2, 5])
    real(rp), parameter :: STILL(3, 3) = 0.0_rp
    integer :: tri(3, 2), t
    real(rp) :: a
    call quad_triangles(SPLIT_MAIN, tri)
    a = 1.0_rp
    do t = 1, 2
      a = min(a, ccd_triangle(oc, 0.0_rp, xq(:, tri(:, t)), STILL, d, SWEPT_KEEP))
    end do
    do t = 1, 5
      a = min(a, ccd_edge(oc, 0.0_rp, xq(:, sides(:, t)), STILL(:, 1:2), d, SWEPT_KEEP))
    end do
    swept = a < 1.0_rp
  end function quad_swept

  !> Node (i, j) is owned and free.
  pure logical function owned_free(lat, fixed, i, j)
    type(lattice_t), intent(in) :: lat
    logical, intent(in) :: fixed(0:, lat%ys:)
    integer, intent(in) :: i, j
    owned_free = .false.
    if (j < lat%ys .or. j > lat%ye) return
    owned_free = .not. fixed(i, j)
  end function owned_free

end module face_elements
