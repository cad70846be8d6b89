! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of the obstacles' surface meshes (module obstacle_mesh):
!> their sizes; every vertex on the shape's surface (contact's signed
!> distance 0); the solids closed and consistently ordered (each directed
!> edge once, its reverse once) with every triangle's normal out of the
!> obstacle (along the signed distance's gradient at its centroid) and the
!> enclosed volume that of the shape (exact for a box, within 4 % for the
!> sphere and capsule, from below: the vertices are on the surface); the
!> plane's patch square, centred at the given point's projection, its
!> normal the plane's; a translated obstacle's mesh the same mesh
!> translated; the tangents of plane_tangents orthonormal with u x w = n.
program test_obstacle_mesh
  use kinds, only: rp
  use vec3, only: cross
  use contact, only: obstacle_t, signed_distance, SHAPE_PLANE, SHAPE_SPHERE, SHAPE_BOX, SHAPE_CAPSULE
  use obstacle_mesh, only: mesh_size, mesh_make, plane_tangents
  use obstacle_motion, only: obstacle_at
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  real(rp), parameter :: PI = acos(-1.0_rp)
  type(obstacle_t) :: sphere, box, capsule, plane, moved
  real(rp), allocatable :: v(:, :), vm(:, :)
  integer, allocatable :: f(:, :), fm(:, :)
  real(rp) :: u(3), w(3), n(3), c(3), r, l, axes(3, 3)
  integer :: nv, nf, k

  call mesh_size(SHAPE_PLANE, nv, nf)
  call check_true(nv == 4 .and. nf == 2, 'plane: 4 vertices, 2 triangles')
  call mesh_size(SHAPE_BOX, nv, nf)
  call check_true(nv == 8 .and. nf == 12, 'box: 8 vertices, 12 triangles')
  call mesh_size(SHAPE_SPHERE, nv, nf)
  call check_true(nv == 382 .and. nf == 760, 'sphere: 382 vertices, 760 triangles')
  call mesh_size(SHAPE_CAPSULE, nv, nf)
  call check_true(nv == 202 .and. nf == 400, 'capsule: 202 vertices, 400 triangles')
  call mesh_size(0, nv, nf)
  call check_true(nv == 0 .and. nf == 0, 'an unknown shape: no mesh')

  ! A sphere off the origin.
  r = 0.3_rp
  sphere = obstacle_t(shape=SHAPE_SPHERE, p=[0.1_rp, -0.2_rp, 0.5_rp], r=r)
  call made(sphere)
  call solid_checks(sphere, 'sphere', 4.0_rp / 3.0_rp * PI * r**3, 0.04_rp)

  ! A rotated box: axes from a unit normal and an axis orthogonal to it.
  n = [1.0_rp, 2.0_rp, 2.0_rp] / 3.0_rp
  u = [2.0_rp, 1.0_rp, -2.0_rp] / 3.0_rp
  axes(:, 1) = u
  axes(:, 2) = cross(n, u)
  axes(:, 3) = n
  box = obstacle_t(shape=SHAPE_BOX, p=[1.0_rp, 0.5_rp, -0.25_rp], h=[0.4_rp, 0.1_rp, 0.25_rp], axes=axes)
  call made(box)
  call solid_checks(box, 'box', 8.0_rp * 0.4_rp * 0.1_rp * 0.25_rp, 1.0e-13_rp)

  ! An oblique capsule.
  capsule = obstacle_t(shape=SHAPE_CAPSULE, p=[0.0_rp, 0.0_rp, 0.1_rp], q=[0.3_rp, 0.4_rp, 0.1_rp], r=0.05_rp)
  l = 0.5_rp
  call made(capsule)
  call solid_checks(capsule, 'capsule', PI * 0.05_rp**2 * l + 4.0_rp / 3.0_rp * PI * 0.05_rp**3, 0.04_rp)
  ! a capsule along the x axis, where the tangents switch to e_y
  capsule = obstacle_t(shape=SHAPE_CAPSULE, p=[0.0_rp, 0.0_rp, 0.0_rp], q=[1.0_rp, 0.0_rp, 0.0_rp], r=0.01_rp)
  call made(capsule)
  call solid_checks(capsule, 'capsule along x', PI * 0.01_rp**2 + 4.0_rp / 3.0_rp * PI * 0.01_rp**3, 0.04_rp)

  ! A tilted plane: the patch centred at the projection of c, side 1.3.
  n = [0.0_rp, -0.6_rp, 0.8_rp]
  plane = obstacle_t(shape=SHAPE_PLANE, p=[0.0_rp, 0.0_rp, -0.05_rp], n=n)
  c = [0.5_rp, 0.5_rp, 0.0_rp]
  call mesh_size(SHAPE_PLANE, nv, nf)
  deallocate(v, f)
  allocate(v(3, nv), f(3, nf))
  call mesh_make(plane, c, 1.3_rp, v, f)
  call check_true(all(f >= 0 .and. f < nv), 'plane: indices in range')
  do k = 1, nv
    call check_close(dot_product(v(:, k) - plane%p, n), 0.0_rp, 0.0_rp, 1.0e-15_rp, 'plane: a corner on the plane')
  end do
  call check_close_array(sum(v, dim=2) / 4.0_rp, c - dot_product(c - plane%p, n) * n, 0.0_rp, 1.0e-15_rp, &
                         'plane: the patch centred at the projection of the given point')
  call check_close(norm2(v(:, 2) - v(:, 1)), 1.3_rp, 1.0e-15_rp, 0.0_rp, 'plane: side')
  call check_close(norm2(v(:, 4) - v(:, 1)), 1.3_rp, 1.0e-15_rp, 0.0_rp, 'plane: other side')
  call check_close(dot_product(v(:, 2) - v(:, 1), v(:, 4) - v(:, 1)), 0.0_rp, 0.0_rp, 1.0e-15_rp, 'plane: square')
  do k = 1, nf
    call check_close_array(unit_normal(v, f(:, k)), n, 0.0_rp, 1.0e-15_rp, 'plane: a triangle''s normal is the plane''s')
  end do

  ! Translated by obstacle_at: the mesh of the moved obstacle is the base's moved.
  call moved_checks(sphere, 'sphere')
  call moved_checks(box, 'box')
  call moved_checks(capsule, 'capsule')
  call mesh_size(SHAPE_PLANE, nv, nf)
  call moved_mesh(plane, moved, vm, fm)
  deallocate(v, f)
  allocate(v(3, nv), f(3, nf))
  call mesh_make(plane, c, 1.3_rp, v, f)
  ! a plane moved along its normal by the keyframes' offset (0, 0.1, 0.2): its patch moves by the normal part
  call check_close_array(reshape(vm - v, [3 * nv]), reshape(spread(dot_product([0.0_rp, 0.1_rp, 0.2_rp], n) * n, 2, nv), &
                         [3 * nv]), 0.0_rp, 1.0e-15_rp, 'plane: moved by the normal part of the translation')

  ! Tangents: orthonormal, u x w = n, for the axes and an oblique normal.
  call tangent_checks([1.0_rp, 0.0_rp, 0.0_rp])
  call tangent_checks([0.0_rp, 1.0_rp, 0.0_rp])
  call tangent_checks([0.0_rp, 0.0_rp, -1.0_rp])
  call tangent_checks([0.48_rp, 0.6_rp, 0.64_rp])

  call check_report()

contains

  !> v, f: the mesh of o (reallocated).
  subroutine made(o)
    type(obstacle_t), intent(in) :: o
    integer :: nv, nf
    if (allocated(v)) deallocate(v, f)
    call mesh_size(o%shape, nv, nf)
    allocate(v(3, nv), f(3, nf))
    call mesh_make(o, [0.0_rp, 0.0_rp, 0.0_rp], 1.0_rp, v, f)
  end subroutine made

  !> The mesh v, f of the solid o: on its surface, closed, ordered, outward, its volume.
  subroutine solid_checks(o, what, volume, rtol)
    type(obstacle_t), intent(in) :: o
    character(*), intent(in) :: what
    real(rp), intent(in) :: volume, rtol
    real(rp) :: d, g(3), hd(3, 3), vol, worst, cent(3)
    integer :: k, m, a, b, once, back
    logical :: outward

    call check_true(all(f >= 0 .and. f < size(v, 2)), what//': indices in range')
    worst = 0.0_rp
    do k = 1, size(v, 2)
      call signed_distance(o, v(:, k), d, g, hd)
      worst = max(worst, abs(d))
    end do
    call check_close(worst, 0.0_rp, 0.0_rp, 1.0e-15_rp, what//': every vertex on the surface')
    ! each directed edge once, and its reverse once: closed, consistently ordered
    once = 0
    back = 0
    do k = 1, size(f, 2)
      do m = 1, 3
        a = f(m, k)
        b = f(mod(m, 3) + 1, k)
        if (count_edge(a, b) == 1) once = once + 1
        if (count_edge(b, a) == 1) back = back + 1
      end do
    end do
    call check_true(once == 3 * size(f, 2) .and. back == 3 * size(f, 2), what//': closed, every edge once each way')
    outward = .true.
    vol = 0.0_rp
    do k = 1, size(f, 2)
      cent = (v(:, f(1, k) + 1) + v(:, f(2, k) + 1) + v(:, f(3, k) + 1)) / 3.0_rp
      call signed_distance(o, cent, d, g, hd)
      outward = outward .and. dot_product(unit_normal(v, f(:, k)), g) > 0.5_rp
      vol = vol + dot_product(v(:, f(1, k) + 1), cross(v(:, f(2, k) + 1), v(:, f(3, k) + 1))) / 6.0_rp
    end do
    call check_true(outward, what//': every triangle''s normal out of the obstacle')
    call check_true(vol <= volume * (1.0_rp + 1.0e-13_rp), what//': volume not above the shape''s')
    call check_close(vol, volume, rtol, 0.0_rp, what//': volume')
  end subroutine solid_checks

  !> How often the directed edge a -> b occurs in f.
  integer function count_edge(a, b) result(c)
    integer, intent(in) :: a, b
    integer :: k, m
    c = 0
    do k = 1, size(f, 2)
      do m = 1, 3
        if (f(m, k) == a .and. f(mod(m, 3) + 1, k) == b) c = c + 1
      end do
    end do
  end function count_edge

  !> The unit normal of triangle t (0-based indices) of vertices vv.
  function unit_normal(vv, t) result(nn)
    real(rp), intent(in) :: vv(:, :)
    integer, intent(in) :: t(3)
    real(rp) :: nn(3)
    nn = cross(vv(:, t(2) + 1) - vv(:, t(1) + 1), vv(:, t(3) + 1) - vv(:, t(1) + 1))
    nn = nn / norm2(nn)
  end function unit_normal

  !> o moved by keyframes to an offset (0, 0.1, 0.2): mo, and its mesh vv, ff.
  subroutine moved_mesh(o, mo, vv, ff)
    type(obstacle_t), intent(in) :: o
    type(obstacle_t), intent(out) :: mo
    real(rp), allocatable, intent(out) :: vv(:, :)
    integer, allocatable, intent(out) :: ff(:, :)
    real(rp) :: off(3, 2)
    integer :: nv, nf
    off(:, 1) = 0.0_rp
    off(:, 2) = [0.0_rp, 0.2_rp, 0.4_rp]
    call obstacle_at(o, [0.0_rp, 2.0_rp], off, [0.0_rp, 0.0_rp], [0.0_rp, 0.0_rp, 0.0_rp], 1.0_rp, mo)
    call mesh_size(o%shape, nv, nf)
    allocate(vv(3, nv), ff(3, nf))
    call mesh_make(mo, c, 1.3_rp, vv, ff)
  end subroutine moved_mesh

  subroutine moved_checks(o, what)
    type(obstacle_t), intent(in) :: o
    character(*), intent(in) :: what
    type(obstacle_t) :: mo
    integer :: nv, nf
    call moved_mesh(o, mo, vm, fm)
    call mesh_size(o%shape, nv, nf)
    if (allocated(v)) deallocate(v, f)
    allocate(v(3, nv), f(3, nf))
    call mesh_make(o, c, 1.3_rp, v, f)
    call check_true(all(fm == f), what//': moved, the same triangles')
    call check_close_array(reshape(vm - v, [3 * nv]), reshape(spread([0.0_rp, 0.1_rp, 0.2_rp], 2, nv), [3 * nv]), &
                           0.0_rp, 1.0e-15_rp, what//': moved, the vertices by the translation')
  end subroutine moved_checks

  subroutine tangent_checks(nn)
    real(rp), intent(in) :: nn(3)
    real(rp) :: uu(3), ww(3)
    call plane_tangents(nn, uu, ww)
    call check_close(norm2(uu), 1.0_rp, 1.0e-15_rp, 0.0_rp, 'tangents: |u| = 1')
    call check_close(norm2(ww), 1.0_rp, 1.0e-15_rp, 0.0_rp, 'tangents: |w| = 1')
    call check_close(dot_product(uu, nn), 0.0_rp, 0.0_rp, 1.0e-15_rp, 'tangents: u . n = 0')
    call check_close(dot_product(uu, ww), 0.0_rp, 0.0_rp, 1.0e-15_rp, 'tangents: u . w = 0')
    call check_close_array(cross(uu, ww), nn, 0.0_rp, 1.0e-15_rp, 'tangents: u x w = n')
  end subroutine tangent_checks

end program test_obstacle_mesh
