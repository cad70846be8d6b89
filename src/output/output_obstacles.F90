! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the obstacles of a scene with contact (&contact), for the
!> eyes: each obstacle's surface as triangles (kernel obstacle_mesh) at its
!> pose, which the writer computes from &contact's keyframes at each output
!> time (poses are a pure function of time; obstacle_pose is the one call
!> into contact), and the sidecar <file>-obstacles.xdmf that names them
!> (submodule output_xdmf). The contact itself never reads them.
!>
!> Layout (C order):
!>   /obstacles                        attributes n_obstacles, description
!>   /obstacles/obstacle_<k>           attributes shape, number (k), moving (0/1)
!>     triangles  int32 [nf][3]        vertex indices (0-based), counter-clockwise seen from outside
!>     number     int32 [nf]           k at each triangle: the sidecar's cell array `obstacle`
!>     vertices   float64 [nv][3]      static (no keyframes, or one), or
!>                float64 [t][nv][3]   moving (keyframes): at each output step, extendable along t
!>   /xdmf/obstacle_<k>_vertices_<t>   [nv][3]: a view of step t of a moving one (as /xdmf/position_<t>)
!> A plane is a square patch of 1.3 times the rest sheet's size (the larger
!> of lx, ly), centred at the projection of the rest sheet's centre
!> (lx/2, ly/2, 0), as postprocess/contact_plot.py draws it.
!>
!> A restart (-nuno_restart) writes the obstacles of its input, which is
!> the file's /config/contact from then on: an obstacle whose layout the
!> file has (its shape, static or moving) keeps its datasets and gets the
!> input's vertices at every kept output step (the same values where the
!> obstacle did not change), another is made anew. So the file shows the
!> obstacles of its /config/contact at every output time.
submodule (output) output_obstacles
  use contact, only: obstacle_t
  use obstacle_set, only: obstacle_from_config
  use obstacle_motion, only: obstacle_at
  use obstacle_mesh, only: mesh_size, mesh_make
  implicit none

  character(len=*), parameter :: WHO = 'output_write_obstacles'
  character(len=*), parameter :: STEP = 'output'    ! agree's name of an output step's writes
  character(len=*), parameter :: SHAPE_NAMES(4) = [character(len=8) :: 'plane', 'sphere', 'box', 'capsule']
  !> a plane's patch: its side in rest sheets
  real(rp), parameter :: PATCH = 1.3_rp

contains

  !> The run's obstacles (cfg%contact; none: nothing) in the file: made, or
  !> made those of the input at a restart, with their vertices at the
  !> out%series%nt output steps the file holds and the views of a moving
  !> one. After output_open or output_reopen, before the next output step.
  !> Collective.
  module procedure output_write_obstacles
    integer(hid_t) :: grp
    integer :: k

    call require_open(out, WHO, ierr, errmsg)
    if (ierr /= 0) return
    call describe(out%obst, cfg)
    if (out%obst%n == 0) return
    call open_or_create_group(out%file, '/obstacles', grp, ierr, errmsg)
    call set_attr_str(grp, 'description', 'the obstacles (&contact) as triangulated surfaces at their poses, '// &
                      'for the sidecar NAME-obstacles.xdmf; not used by the contact', '/obstacles', ierr, errmsg)
    call set_attr_int(grp, 'n_obstacles', out%obst%n, '/obstacles', ierr, errmsg)
    call close_group(grp, '/obstacles', ierr, errmsg)
    call agree(out%comm, WHO, ierr, errmsg)
    do k = 1, out%obst%n
      if (ierr /= 0) exit
      call obstacle_made(out, k, ierr, errmsg)
    end do
    if (ierr == 0) call flush_file(out, ierr, errmsg)
    call agree(out%comm, WHO, ierr, errmsg)
  end procedure output_write_obstacles

  !> The vertices of the moving obstacles at this output step (the file's
  !> step out%series%nt, at `time`), and their views. Collective; nothing
  !> without obstacles.
  module procedure obstacles_step
    integer :: k
    integer(hsize_t) :: nt, nv

    if (ierr /= 0) return
    nt = int(out%series%nt, hsize_t)
    do k = 1, out%obst%n
      if (.not. out%obst%moving(k)) cycle
      call step_vertices(out, k, time, ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
      nv = int(out%obst%nv(k), hsize_t)
      call make_view_dims(out, obstacle_view(k, out%series%nt), vertices_path(k), [0_hsize_t, 0_hsize_t, nt], &
                          [3_hsize_t, nv, 1_hsize_t], [3_hsize_t, nv], ierr, errmsg)
      if (.not. all_agree(out%comm, STEP, ierr, errmsg)) return
    end do
  end procedure obstacles_step

  !> Rank 0, at the commit of a run without obstacles: an earlier run's
  !> obstacles' sidecar (nuno's: its first lines) is removed, since it
  !> names the obstacles of a file that this run replaces.
  module procedure drop_obstacles_sidecar
    character(len=256) :: why
    logical :: ok

    if (path_kind(out%safe%obst_path, why) /= kind_file) return
    if (.not. is_nuno_sidecar(out%safe%obst_path)) return
    call remove_file(out%safe%obst_path, ok, why)
    if (.not. ok .and. ierr == 0) then
      ierr = 1
      errmsg = 'output: cannot remove the earlier run''s '//out%safe%obst_path//' (this run has no obstacles): '//trim(why)
    end if
  end procedure drop_obstacles_sidecar

  ! ------------------------------------------------------------ the poses

  !> Obstacle k of cc at time t: its pose at zero offset
  !> (obstacle_set's obstacle_from_config) moved by its keyframes
  !> (obstacle_motion's obstacle_at), as contact evaluates it. The one
  !> place that asks contact for an obstacle's pose.
  pure function obstacle_pose(cc, k, t) result(o)
    type(contact_config), intent(in) :: cc
    integer, intent(in) :: k
    real(rp), intent(in) :: t
    type(obstacle_t) :: o
    type(obstacle_t) :: base
    integer :: m

    base = obstacle_from_config(cc, k)
    m = cc%n_keyframes(k)
    if (m == 0) then
      o = base
    else
      call obstacle_at(base, cc%key_time(1:m, k), cc%key_offset(:, 1:m, k), cc%key_close(1:m, k), cc%close_dir(:, k), &
                       t, o)
    end if
  end function obstacle_pose

  !> Obstacle k's mesh at time t: vertices v(3, nv), triangles f(3, nf).
  subroutine mesh_at(ob, k, t, v, f)
    type(obstacles_state), intent(in) :: ob
    integer, intent(in) :: k
    real(rp), intent(in) :: t
    real(rp), intent(out) :: v(:, :)
    integer, intent(out) :: f(:, :)
    call mesh_make(obstacle_pose(ob%cc, k, t), ob%centre, ob%side, v, f)
  end subroutine mesh_at

  !> The record of the obstacles of cfg (n = 0 without).
  subroutine describe(ob, cfg)
    type(obstacles_state), intent(out) :: ob
    type(nuno_config), intent(in) :: cfg
    integer :: k, code

    ob%n = max(0, cfg%contact%n_obstacles)
    if (ob%n == 0) return
    ob%cc = cfg%contact
    ob%centre = [0.5_rp * cfg%lattice%lx, 0.5_rp * cfg%lattice%ly, 0.0_rp]
    ob%side = PATCH * max(cfg%lattice%lx, cfg%lattice%ly)
    select case (trim(cfg%scene%units))
    case ('SI')
      ob%units = 'm'
    case ('mm g s')
      ob%units = 'mm'
    case default
      ob%units = ''
    end select
    allocate(ob%shape(ob%n), ob%nv(ob%n), ob%nf(ob%n), ob%moving(ob%n))
    do k = 1, ob%n
      code = cfg%contact%shape_code(k)
      ob%shape(k) = 'unknown'
      if (code >= 1 .and. code <= size(SHAPE_NAMES)) ob%shape(k) = SHAPE_NAMES(code)
      call mesh_size(code, ob%nv(k), ob%nf(k))
      ! one keyframe: held at its offset, a static pose
      ob%moving(k) = cfg%contact%n_keyframes(k) >= 2
    end do
  end subroutine describe

  ! --------------------------------------------------------- the datasets

  !> Obstacle k's group and datasets: kept where the file has them in its
  !> layout, made otherwise; its values at the file's output steps; a
  !> moving one's views. Collective.
  subroutine obstacle_made(out, k, ierr, errmsg)
    type(output_file), intent(inout) :: out
    integer, intent(in) :: k
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: extent
    logical :: kept

    call keep_or_drop(out, k, kept, extent, ierr, errmsg)
    if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
    if (.not. kept) call make_datasets(out, k, ierr, errmsg)
    if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
    call write_mesh(out, k, ierr, errmsg)
    if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
    ! views: of the steps after the file's (a kept one), or all of an old
    ! layout's (a moving one made static keeps none)
    if (out%obst%moving(k) .or. .not. kept) &
      call sync_obstacle_views(out, k, merge(out%series%nt, 0, kept), extent, ierr, errmsg)
  end subroutine obstacle_made

  !> kept: the file has obstacle k's group in the layout of this run (its
  !> shape, static or moving, its vertices); extent: the steps of its
  !> vertices there (moving: the views it may have). A group in another
  !> layout is deleted. Collective (metadata).
  subroutine keep_or_drop(out, k, kept, extent, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: k
    logical, intent(out) :: kept
    integer, intent(out) :: extent
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp, dset
    integer(hsize_t) :: dims(4)
    integer :: h, r
    logical :: exists
    character(len=32) :: shape
    character(len=:), allocatable :: path

    kept = .false.
    extent = 0
    path = group_path(k)
    call has_link(out%file, path, path, exists, ierr, errmsg)
    if (ierr /= 0 .or. .not. exists) return
    call h5gopen_f(out%file, path, grp, h)
    if (h < 0) then
      call fail('h5gopen_f', path, ierr, errmsg); return
    end if
    call get_attr_str(grp, 'shape', path, shape, ierr, errmsg)
    call close_group(grp, path, ierr, errmsg)
    call open_dset(out%file, vertices_path(k), dset, ierr, errmsg)
    call dset_dims(dset, vertices_path(k), r, dims, ierr, errmsg)
    call close_dset(dset, vertices_path(k), ierr, errmsg)
    if (ierr /= 0) return
    if (r == 3) extent = int(dims(3))
    kept = trim(shape) == trim(out%obst%shape(k)) .and. r == merge(3, 2, out%obst%moving(k)) .and. &
           dims(2) == int(out%obst%nv(k), hsize_t)
    if (kept) return
    call h5ldelete_f(out%file, path, h)
    if (h < 0) call fail('h5ldelete_f', path, ierr, errmsg)
  end subroutine keep_or_drop

  !> Obstacle k's group, its attributes and empty datasets. Collective.
  subroutine make_datasets(out, k, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: k
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: grp, dset
    integer(hsize_t) :: nv, nf
    character(len=:), allocatable :: path

    path = group_path(k)
    nv = int(out%obst%nv(k), hsize_t)
    nf = int(out%obst%nf(k), hsize_t)
    call open_or_create_group(out%file, path, grp, ierr, errmsg)
    call set_attr_str(grp, 'shape', trim(out%obst%shape(k)), path, ierr, errmsg)
    call set_attr_int(grp, 'number', k, path, ierr, errmsg)
    call set_attr_int(grp, 'moving', merge(1, 0, out%obst%moving(k)), path, ierr, errmsg)
    call create_dataset(grp, 'triangles', H5T_NATIVE_INTEGER, [3_hsize_t, nf], dset, ierr, errmsg)
    call set_attr_str(dset, 'description', 'the triangles [nf][3]: 0-based indices of their vertices, '// &
                      'counter-clockwise seen from outside', path//'/triangles', ierr, errmsg)
    call close_dset(dset, path//'/triangles', ierr, errmsg)
    call create_dataset(grp, 'number', H5T_NATIVE_INTEGER, [nf], dset, ierr, errmsg)
    call set_attr_str(dset, 'description', 'the obstacle''s number at each triangle [nf]', path//'/number', ierr, errmsg)
    call close_dset(dset, path//'/number', ierr, errmsg)
    if (out%obst%moving(k)) then
      call create_extendable(grp, 'vertices', H5T_NATIVE_DOUBLE, [3_hsize_t, nv, 0_hsize_t], &
                             [3_hsize_t, nv, H5S_UNLIMITED_F], [3_hsize_t, nv, 1_hsize_t], dset, ierr, errmsg)
      call set_attr_str(dset, 'description', 'the vertices [t][nv][xyz] at each output step', path//'/vertices', &
                        ierr, errmsg)
    else
      call create_dataset(grp, 'vertices', H5T_NATIVE_DOUBLE, [3_hsize_t, nv], dset, ierr, errmsg)
      call set_attr_str(dset, 'description', 'the vertices [nv][xyz] (a static obstacle)', path//'/vertices', ierr, errmsg)
    end if
    if (len_trim(out%obst%units) > 0) call set_attr_str(dset, 'units', trim(out%obst%units), path//'/vertices', &
                                                        ierr, errmsg)
    call close_dset(dset, path//'/vertices', ierr, errmsg)
    call close_group(grp, path, ierr, errmsg)
  end subroutine make_datasets

  !> Obstacle k's triangles, numbers and vertices (static: once; moving: at
  !> each of the file's out%series%nt output times, the extent cut or
  !> grown to them). Rank 0 writes; collective.
  subroutine write_mesh(out, k, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: k
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp), allocatable :: v(:, :, :)
    integer, allocatable :: f(:, :)
    integer(hsize_t) :: nv, nf, nt
    integer :: t, h
    integer(hid_t) :: dset
    character(len=:), allocatable :: path

    nv = int(out%obst%nv(k), hsize_t)
    nf = int(out%obst%nf(k), hsize_t)
    nt = int(out%series%nt, hsize_t)
    allocate(f(3, nf), v(3, nv, max(1_hsize_t, nt)))
    call mesh_at(out%obst, k, 0.0_rp, v(:, :, 1), f)
    path = group_path(k)
    call open_dset(out%file, path//'/triangles', dset, ierr, errmsg)
    call put_ints(out, dset, path//'/triangles', [0_hsize_t, 0_hsize_t], [3_hsize_t, nf], reshape(f, [size(f)]), &
                  ierr, errmsg)
    call close_dset(dset, path//'/triangles', ierr, errmsg)
    if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
    call open_dset(out%file, path//'/number', dset, ierr, errmsg)
    call put_ints(out, dset, path//'/number', [0_hsize_t], [nf], spread(k, 1, int(nf)), ierr, errmsg)
    call close_dset(dset, path//'/number', ierr, errmsg)
    if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
    call open_dset(out%file, vertices_path(k), dset, ierr, errmsg)
    if (.not. out%obst%moving(k)) then
      call put_reals(out, dset, vertices_path(k), [0_hsize_t, 0_hsize_t], [3_hsize_t, nv], &
                     reshape(v(:, :, 1), [3 * nv]), ierr, errmsg)
    else
      if (ierr == 0) then
        call h5dset_extent_f(dset, [3_hsize_t, nv, nt], h)
        if (h < 0) call fail('h5dset_extent_f', vertices_path(k), ierr, errmsg)
      end if
      do t = 1, int(nt)
        call mesh_at(out%obst, k, out%series%times(t), v(:, :, t), f)
      end do
      if (all_agree(out%comm, WHO, ierr, errmsg) .and. nt > 0) &
        call put_reals(out, dset, vertices_path(k), [0_hsize_t, 0_hsize_t, 0_hsize_t], [3_hsize_t, nv, nt], &
                       reshape(v, [size(v)]), ierr, errmsg)
    end if
    call close_dset(dset, vertices_path(k), ierr, errmsg)
  end subroutine write_mesh

  !> Moving obstacle k's vertices at the new output step out%series%nt, at
  !> `time`: the dataset grown by a step, rank 0 writes. Collective.
  subroutine step_vertices(out, k, time, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: k
    real(rp), intent(in) :: time
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    real(rp), allocatable :: v(:, :)
    integer, allocatable :: f(:, :)
    integer(hsize_t) :: nv, nt
    integer(hid_t) :: dset
    integer :: h

    nv = int(out%obst%nv(k), hsize_t)
    nt = int(out%series%nt, hsize_t)
    allocate(v(3, nv), f(3, out%obst%nf(k)))
    call mesh_at(out%obst, k, time, v, f)
    call open_dset(out%file, vertices_path(k), dset, ierr, errmsg)
    if (ierr == 0) then
      call h5dset_extent_f(dset, [3_hsize_t, nv, nt + 1], h)
      if (h < 0) call fail('h5dset_extent_f', vertices_path(k), ierr, errmsg)
    end if
    if (all_agree(out%comm, STEP, ierr, errmsg)) &
      call put_reals(out, dset, vertices_path(k), [0_hsize_t, 0_hsize_t, nt], [3_hsize_t, nv, 1_hsize_t], &
                     reshape(v, [size(v)]), ierr, errmsg)
    call close_dset(dset, vertices_path(k), ierr, errmsg)
  end subroutine step_vertices

  !> Obstacle k's views: those of steps first.. deleted (up to extent, and
  !> on while there are more); a moving one's of the file's steps made
  !> where missing. Collective; each change agreed on before the next.
  subroutine sync_obstacle_views(out, k, first, extent, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(in) :: k, first, extent
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: t
    integer(hsize_t) :: nv
    logical :: exists
    character(len=:), allocatable :: view

    nv = int(out%obst%nv(k), hsize_t)
    t = first
    do
      view = obstacle_view(k, t)
      call has_link(out%file, '/xdmf/'//view, '/xdmf/'//view, exists, ierr, errmsg)
      if (ierr == 0 .and. .not. exists .and. t >= extent) exit
      if (exists) call drop_view(out, view, ierr, errmsg)
      if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
      t = t + 1
    end do
    if (.not. out%obst%moving(k)) return
    do t = 0, out%series%nt - 1
      view = obstacle_view(k, t)
      call has_link(out%file, '/xdmf/'//view, '/xdmf/'//view, exists, ierr, errmsg)
      if (ierr == 0 .and. .not. exists) &
        call make_view_dims(out, view, vertices_path(k), [0_hsize_t, 0_hsize_t, int(t, hsize_t)], &
                            [3_hsize_t, nv, 1_hsize_t], [3_hsize_t, nv], ierr, errmsg)
      if (.not. all_agree(out%comm, WHO, ierr, errmsg)) return
    end do
  end subroutine sync_obstacle_views

  ! ---------------------------------------------------------------- writes

  !> Rank 0 writes a (count's values, Fortran order) at start of dset
  !> (name); the others join the collective call with nothing.
  subroutine put_reals(out, dset, name, start, count, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    real(rp), intent(in) :: a(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer :: h

    if (ierr /= 0) return
    call select_spaces(dset, name, start, count, out%rank /= 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dwrite_f(dset, H5T_NATIVE_DOUBLE, a, [int(size(a), hsize_t)], h, mem_space_id=mspace, &
                      file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine put_reals

  !> put_reals of default integers (int32).
  subroutine put_ints(out, dset, name, start, count, a, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer(hid_t), intent(in) :: dset
    character(*), intent(in) :: name
    integer(hsize_t), intent(in) :: start(:), count(:)
    integer, intent(in) :: a(:)
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace
    integer :: h

    if (ierr /= 0) return
    call select_spaces(dset, name, start, count, out%rank /= 0, fspace, mspace, ierr, errmsg)
    if (ierr == 0) then
      call h5dwrite_f(dset, H5T_NATIVE_INTEGER, a, [int(size(a), hsize_t)], h, mem_space_id=mspace, &
                      file_space_id=fspace, xfer_prp=out%dxpl)
      if (h < 0) call fail('h5dwrite_f', name, ierr, errmsg)
    end if
    call close_spaces(fspace, mspace, name, ierr, errmsg)
  end subroutine put_ints

  ! ----------------------------------------------------------------- names

  function group_path(k) result(path)
    integer, intent(in) :: k
    character(len=:), allocatable :: path
    path = '/obstacles/obstacle_'//itoa(k)
  end function group_path

  function vertices_path(k) result(path)
    integer, intent(in) :: k
    character(len=:), allocatable :: path
    path = group_path(k)//'/vertices'
  end function vertices_path

  !> The name in /xdmf of the view of step t (0-based) of moving obstacle k.
  module procedure obstacle_view
    name = 'obstacle_'//itoa(k)//'_vertices_'//itoa(t)
  end procedure obstacle_view

end submodule output_obstacles
