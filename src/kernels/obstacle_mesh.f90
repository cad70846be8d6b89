! SPDX-License-Identifier: BSD-2-Clause
!> An obstacle's surface as triangles, for the eyes (the XDMF sidecar of
!> the obstacles, module output): a plane as a square patch, a sphere of
!> 760 triangles, a box of 12, a capsule of 400 (a cylinder and two half
!> spheres), each a closed surface (but the plane) with its triangles
!> ordered so that their normals point out of the obstacle. The vertices
!> lie on the shape's surface (contact's signed distance 0; not offset by
!> contact_thickness); the shape between them is the shape's polyhedral
!> approximation, which the contact does not use. Plain arrays, no PETSc,
!> no MPI, no allocation. tests/unit/test_obstacle_mesh.f90.
module obstacle_mesh
  use kinds, only: rp
  use vec3, only: cross
  use contact, only: obstacle_t, SHAPE_PLANE, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE
  implicit none
  private
  public :: mesh_size, mesh_make, plane_tangents
  public :: SECTORS, SPHERE_BANDS, CAP_BANDS

  !> Points around a sphere's or capsule's axis (its meridians).
  integer, parameter :: SECTORS = 20
  !> Bands of a sphere from pole to pole (19 rings: 2 + 19*20 = 382 vertices, 760 triangles).
  integer, parameter :: SPHERE_BANDS = 20
  !> Bands of each half sphere of a capsule, pole to equator (10 rings: 202 vertices, 400 triangles).
  integer, parameter :: CAP_BANDS = 5

  real(rp), parameter :: PI = acos(-1.0_rp)

contains

  !> The numbers of vertices nv and triangles nf of a shape's mesh (0, 0
  !> for a shape this module does not know).
  pure subroutine mesh_size(shape, nv, nf)
    integer, intent(in) :: shape
    integer, intent(out) :: nv, nf

    select case (shape)
    case (SHAPE_PLANE)
      nv = 4; nf = 2
    case (SHAPE_BOX)
      nv = 8; nf = 12
    case (SHAPE_SPHERE)
      call rings_size(SPHERE_BANDS - 1, nv, nf)
    case (SHAPE_CAPSULE)
      call rings_size(2 * CAP_BANDS, nv, nf)
    case default
      nv = 0; nf = 0
    end select
  end subroutine mesh_size

  !> The mesh of obstacle o at its pose: vertices v(3, nv) [length] and
  !> triangles f(3, nf) (0-based vertex indices, counter-clockwise seen
  !> from outside), nv and nf of mesh_size. A plane is the square patch of
  !> side `side` centred at the point `centre` projected onto it, its
  !> sides along plane_tangents (the patch of postprocess/contact_plot.py).
  pure subroutine mesh_make(o, centre, side, v, f)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: centre(3)   ! a plane's patch: centred at this point's projection [length]
    real(rp), intent(in) :: side        ! a plane's patch: its side [length]
    real(rp), intent(out) :: v(:, :)    ! (3, nv) [length]
    integer, intent(out) :: f(:, :)     ! (3, nf)
    real(rp) :: e(3), l

    select case (o%shape)
    case (SHAPE_PLANE)
      call plane_patch(o, centre, side, v, f)
    case (SHAPE_BOX)
      call box_mesh(o, v, f)
    case (SHAPE_SPHERE)
      call sphere_mesh(o%p, o%r, v, f)
    case (SHAPE_CAPSULE)
      e = o%q - o%p
      l = norm2(e)
      if (l > 0.0_rp) then
        e = e / l
      else
        e = [0.0_rp, 0.0_rp, 1.0_rp]
      end if
      call capsule_mesh(o%p, o%q, e, o%r, v, f)
    end select
  end subroutine mesh_make

  !> Two unit vectors u, w orthogonal to the unit n, with u x w = n: u
  !> along n x e_x (n x e_y where n is within 26 degrees of e_x).
  pure subroutine plane_tangents(n, u, w)
    real(rp), intent(in) :: n(3)
    real(rp), intent(out) :: u(3), w(3)
    real(rp) :: a(3)

    a = [1.0_rp, 0.0_rp, 0.0_rp]
    if (abs(n(1)) >= 0.9_rp) a = [0.0_rp, 1.0_rp, 0.0_rp]
    u = cross(n, a)
    u = u / norm2(u)
    w = cross(n, u)
  end subroutine plane_tangents

  ! ------------------------------------------------------------- the shapes

  !> The plane's square patch: 4 corners, 2 triangles whose normal is n.
  pure subroutine plane_patch(o, centre, side, v, f)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(in) :: centre(3), side
    real(rp), intent(out) :: v(:, :)
    integer, intent(out) :: f(:, :)
    real(rp) :: n(3), c(3), u(3), w(3), h

    n = o%n / norm2(o%n)
    c = centre - dot_product(centre - o%p, n) * n
    call plane_tangents(n, u, w)
    h = 0.5_rp * side
    v(:, 1) = c - h * u - h * w
    v(:, 2) = c + h * u - h * w
    v(:, 3) = c + h * u + h * w
    v(:, 4) = c - h * u + h * w
    f(:, 1) = [0, 1, 2]
    f(:, 2) = [0, 2, 3]
  end subroutine plane_patch

  !> The box's 8 corners (index x + 2 y + 4 z of the corner's side along
  !> each local axis, 1 for +) and its 6 faces, 2 triangles each.
  pure subroutine box_mesh(o, v, f)
    type(obstacle_t), intent(in) :: o
    real(rp), intent(out) :: v(:, :)
    integer, intent(out) :: f(:, :)
    ! each face's corners in order round it, (b - a) x (d - a) outward:
    ! -x, +x, -y, +y, -z, +z
    integer, parameter :: FACES(4, 6) = reshape([0, 4, 6, 2, 1, 3, 7, 5, 0, 1, 5, 4, 2, 6, 7, 3, &
                                                 0, 2, 3, 1, 4, 5, 7, 6], [4, 6])
    integer :: k, a

    do k = 0, 7
      v(:, k + 1) = o%p + side(k, 1) * o%h(1) * o%axes(:, 1) + side(k, 2) * o%h(2) * o%axes(:, 2) + &
                    side(k, 4) * o%h(3) * o%axes(:, 3)
    end do
    do a = 1, 6
      f(:, 2 * a - 1) = FACES([1, 2, 3], a)
      f(:, 2 * a) = FACES([1, 3, 4], a)
    end do
  contains
    !> -1 or +1: bit `bit` (1, 2, 4) of corner k.
    pure real(rp) function side(k, bit)
      integer, intent(in) :: k, bit
      side = merge(1.0_rp, -1.0_rp, iand(k, bit) /= 0)
    end function side
  end subroutine box_mesh

  !> A sphere of centre c and radius r: poles along z, SPHERE_BANDS - 1 rings.
  pure subroutine sphere_mesh(c, r, v, f)
    real(rp), intent(in) :: c(3), r
    real(rp), intent(out) :: v(:, :)
    integer, intent(out) :: f(:, :)
    real(rp) :: height(SPHERE_BANDS - 1), radius(SPHERE_BANDS - 1), th
    integer :: k

    do k = 1, SPHERE_BANDS - 1
      th = PI * real(k, rp) / real(SPHERE_BANDS, rp)
      height(k) = r * cos(th)
      radius(k) = r * sin(th)
    end do
    call ring_surface(c + r * [0.0_rp, 0.0_rp, 1.0_rp], c - r * [0.0_rp, 0.0_rp, 1.0_rp], c, &
                      [0.0_rp, 0.0_rp, 1.0_rp], height, radius, v, f)
  end subroutine sphere_mesh

  !> A capsule from p to q (unit axis e) of radius r: the half sphere at q
  !> (pole q + r e), then the one at p (pole p - r e); the band between
  !> their equators is the cylinder.
  pure subroutine capsule_mesh(p, q, e, r, v, f)
    real(rp), intent(in) :: p(3), q(3), e(3), r
    real(rp), intent(out) :: v(:, :)
    integer, intent(out) :: f(:, :)
    real(rp) :: height(2 * CAP_BANDS), radius(2 * CAP_BANDS), th, l
    integer :: k

    l = dot_product(q - p, e)
    do k = 1, CAP_BANDS
      th = 0.5_rp * PI * real(k, rp) / real(CAP_BANDS, rp)          ! from the pole at q to its equator
      height(k) = l + r * cos(th)
      radius(k) = r * sin(th)
      th = 0.5_rp * PI * real(CAP_BANDS + k - 1, rp) / real(CAP_BANDS, rp)   ! from p's equator to its pole
      height(CAP_BANDS + k) = r * cos(th)
      radius(CAP_BANDS + k) = r * sin(th)
    end do
    call ring_surface(q + r * e, p - r * e, p, e, height, radius, v, f)
  end subroutine capsule_mesh

  ! --------------------------------------------------- rings about an axis

  !> nv and nf of a ring surface of nr rings of SECTORS points and two poles.
  pure subroutine rings_size(nr, nv, nf)
    integer, intent(in) :: nr
    integer, intent(out) :: nv, nf
    nv = 2 + nr * SECTORS
    nf = 2 * SECTORS + 2 * (nr - 1) * SECTORS
  end subroutine rings_size

  !> A closed surface about the unit axis e through o: the pole `top`
  !> (vertex 0), rings k = 1..nr of SECTORS points at o + height(k) e
  !> with radius(k) (from top down: height falls), the pole `bottom`
  !> (the last vertex); fans at the poles, two triangles a quad between
  !> rings, all counter-clockwise seen from outside.
  pure subroutine ring_surface(top, bottom, o, e, height, radius, v, f)
    real(rp), intent(in) :: top(3), bottom(3), o(3), e(3), height(:), radius(:)
    real(rp), intent(out) :: v(:, :)
    integer, intent(out) :: f(:, :)
    real(rp) :: u(3), w(3), phi
    integer :: k, j, jn, nr, last, m

    nr = size(height)
    call plane_tangents(e, u, w)
    v(:, 1) = top
    do k = 1, nr
      do j = 0, SECTORS - 1
        phi = 2.0_rp * PI * real(j, rp) / real(SECTORS, rp)
        v(:, 2 + (k - 1) * SECTORS + j) = o + height(k) * e + radius(k) * (cos(phi) * u + sin(phi) * w)
      end do
    end do
    last = 1 + nr * SECTORS
    v(:, last + 1) = bottom
    m = 0
    do j = 0, SECTORS - 1
      jn = mod(j + 1, SECTORS)
      m = m + 1
      f(:, m) = [0, at(1, j), at(1, jn)]
      do k = 1, nr - 1
        f(:, m + 1) = [at(k, j), at(k + 1, j), at(k + 1, jn)]
        f(:, m + 2) = [at(k, j), at(k + 1, jn), at(k, jn)]
        m = m + 2
      end do
      m = m + 1
      f(:, m) = [last, at(nr, jn), at(nr, j)]
    end do
  contains
    !> The 0-based index of point j of ring k.
    pure integer function at(k, j)
      integer, intent(in) :: k, j
      at = 1 + (k - 1) * SECTORS + j
    end function at
  end subroutine ring_surface

end module obstacle_mesh
