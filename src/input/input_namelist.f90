! SPDX-License-Identifier: BSD-2-Clause
!> The namelist reader's side of the input: one READ of a group's records
!> over the configuration, or one WRITE of a group's values. Fortran names
!> a namelist group's objects by variables in scope, so the keys are
!> declared here once, as pointers into the configuration's records: the
!> reader reads into the configuration itself, and a WRITE shows exactly
!> the keys a READ takes. A key added here goes into module input_keys'
!> table too (name, group, type, unit, default, meaning):
!> tests/mpi/test_input_keys.F90 fails until the two agree. No MPI, no PETSc.
module input_namelist
  use kinds, only: rp
  use config, only: nuno_config, label_len, path_len
  use input_keys, only: G_LATTICE, G_MATERIAL, G_SCENE, G_TIME, G_OUTPUT, G_IDENTIFY, G_CONTROL, G_CONTACT
  implicit none
  private
  public :: namelist_read, namelist_write

  !> What namelist_transfer does with the group: read it, or write it.
  integer, parameter :: NML_READ = 1, NML_WRITE = 2
  !> Records of a group's WRITE: the longest record holds petsc_options
  !> (1024 characters) with its name; &contact's arrays take the most records.
  integer, parameter :: record_len = 2048, max_records = 200

contains

  !> One namelist READ of group g (a G_* code of module input_keys) from the
  !> records `lines`, over cfg. On failure (ios /= 0, iomsg says why) the
  !> keys before the fault may have been read into cfg: the caller drops it.
  subroutine namelist_read(g, lines, cfg, ios, iomsg)
    integer, intent(in) :: g
    character(*), intent(in) :: lines(:)
    type(nuno_config), intent(inout), target :: cfg
    integer, intent(out) :: ios
    character(*), intent(inout) :: iomsg
    character(1) :: no_records(0)
    call namelist_transfer(NML_READ, g, lines, no_records, cfg, ios, iomsg)
  end subroutine namelist_read

  !> The namelist text of group g with cfg's values, as the reader's own
  !> namelist WRITE gives it (gfortran: upper-case names; the key `scene` as
  !> SCENE_NAME), its records joined by line feeds; ios /= 0 when it fails.
  subroutine namelist_write(g, cfg, text, ios)
    integer, intent(in) :: g
    type(nuno_config), intent(in) :: cfg
    character(:), allocatable, intent(out) :: text
    integer, intent(out) :: ios
    character(record_len), allocatable :: records(:)
    character(1) :: no_lines(0)
    character(1024) :: iomsg
    type(nuno_config), target :: c
    integer :: k
    text = ''
    allocate(records(max_records))
    records = ''
    iomsg = ''
    c = cfg
    call namelist_transfer(NML_WRITE, g, no_lines, records, c, ios, iomsg)
    if (ios /= 0) return
    do k = 1, size(records)
      if (len_trim(records(k)) > 0) text = text//trim(records(k))//new_line('a')
    end do
  end subroutine namelist_write

  !> Group g read from `lines` into cfg (mode NML_READ) or written from cfg
  !> into `records` (NML_WRITE). Namelist objects must be variables: the
  !> keys are pointers into cfg's records, named as the keys.
  subroutine namelist_transfer(mode, g, lines, records, cfg, ios, iomsg)
    integer, intent(in) :: mode, g
    character(*), intent(in) :: lines(:)
    character(*), intent(inout) :: records(:)
    type(nuno_config), intent(inout), target :: cfg
    integer, intent(out) :: ios
    character(*), intent(inout) :: iomsg
    integer, pointer :: nx, ny, n_keyframes, n_obstacles, obstacle_n_keyframes(:)
    real(rp), pointer :: lx, ly, total_mass, e_s, eta_s, e_d, eta_d, k_b, eta_b
    real(rp), pointer :: gravity(:), lift_length, lift_height, bend_angle, release_time, initial_omega(:)
    real(rp), pointer :: keyframe_time(:), keyframe_dx(:), keyframe_dy(:), keyframe_dz(:)
    real(rp), pointer :: t_end, dt, output_interval, stretch_limit, checkpoint_interval
    real(rp), pointer :: fit_lower(:), fit_upper(:), tikhonov, max_speed, velocity_weight, keyframe_tikhonov
    real(rp), pointer :: obstacle_point(:, :), obstacle_normal(:, :), obstacle_radius(:), obstacle_mu(:), &
                         obstacle_half_size(:, :), obstacle_axis(:, :), obstacle_end(:, :), obstacle_time(:, :), &
                         obstacle_offset(:, :, :), obstacle_close(:, :), obstacle_close_dir(:, :)
    real(rp), pointer :: contact_thickness, contact_dhat, contact_stiffness, friction_eps_v
    logical, pointer :: write_velocity, contact_faces, self_contact
    real(rp), pointer :: self_mu
    character(label_len), pointer :: mass_distribution, lattice_scaling, spring_model, bending_model, &
                                     wave_nodes, units, components, obstacle_shape(:), self_step
    character(label_len), pointer :: scene_name   ! the key `scene` (renamed by module input_scan)
    character(path_len), pointer :: output_file, observed_file, target_file
    character(len(cfg%output%petsc_options)), pointer :: petsc_options
    character(len(cfg%identify%fit)), pointer :: fit
    namelist /lattice/ nx, ny, lx, ly, total_mass, mass_distribution, lattice_scaling
    namelist /material/ spring_model, e_s, eta_s, e_d, eta_d, bending_model, k_b, eta_b
    namelist /scene/ scene_name, gravity, lift_length, lift_height, bend_angle, n_keyframes, &
                     keyframe_time, keyframe_dx, keyframe_dy, keyframe_dz, wave_nodes, release_time, initial_omega, units
    namelist /time/ t_end, dt
    namelist /output/ output_interval, write_velocity, output_file, petsc_options, stretch_limit, &
                      checkpoint_interval
    namelist /identify/ observed_file, fit, fit_lower, fit_upper, tikhonov
    namelist /control/ target_file, components, max_speed, velocity_weight, keyframe_tikhonov
    namelist /contact/ n_obstacles, obstacle_shape, obstacle_point, obstacle_normal, obstacle_radius, obstacle_mu, &
                       contact_thickness, contact_dhat, contact_stiffness, friction_eps_v, contact_faces, self_contact, self_mu, self_step, &
                       obstacle_half_size, obstacle_axis, obstacle_end, obstacle_n_keyframes, obstacle_time, &
                       obstacle_offset, obstacle_close, obstacle_close_dir

    nx => cfg%lattice%nx; ny => cfg%lattice%ny; lx => cfg%lattice%lx; ly => cfg%lattice%ly
    total_mass => cfg%lattice%total_mass; mass_distribution => cfg%lattice%mass_distribution
    lattice_scaling => cfg%lattice%lattice_scaling
    spring_model => cfg%material%spring_model; e_s => cfg%material%e_s; eta_s => cfg%material%eta_s
    e_d => cfg%material%e_d; eta_d => cfg%material%eta_d; bending_model => cfg%material%bending_model
    k_b => cfg%material%k_b; eta_b => cfg%material%eta_b
    scene_name => cfg%scene%name; gravity => cfg%scene%gravity; lift_length => cfg%scene%lift_length
    lift_height => cfg%scene%lift_height; bend_angle => cfg%scene%bend_angle; n_keyframes => cfg%scene%n_keyframes
    keyframe_time => cfg%scene%keyframe_time; keyframe_dx => cfg%scene%keyframe_dx
    keyframe_dy => cfg%scene%keyframe_dy; keyframe_dz => cfg%scene%keyframe_dz; wave_nodes => cfg%scene%wave_nodes
    release_time => cfg%scene%release_time; initial_omega => cfg%scene%initial_omega; units => cfg%scene%units
    t_end => cfg%time%t_end; dt => cfg%time%dt
    output_interval => cfg%output%output_interval; write_velocity => cfg%output%write_velocity
    output_file => cfg%output%output_file; petsc_options => cfg%output%petsc_options
    stretch_limit => cfg%output%stretch_limit; checkpoint_interval => cfg%output%checkpoint_interval
    observed_file => cfg%identify%observed_file; fit => cfg%identify%fit; fit_lower => cfg%identify%fit_lower
    fit_upper => cfg%identify%fit_upper; tikhonov => cfg%identify%tikhonov
    target_file => cfg%control%target_file; components => cfg%control%components
    max_speed => cfg%control%max_speed; velocity_weight => cfg%control%velocity_weight
    keyframe_tikhonov => cfg%control%keyframe_tikhonov
    n_obstacles => cfg%contact%n_obstacles; obstacle_shape => cfg%contact%shape; obstacle_point => cfg%contact%point
    obstacle_normal => cfg%contact%normal; obstacle_radius => cfg%contact%radius; obstacle_mu => cfg%contact%mu
    contact_thickness => cfg%contact%thickness; contact_dhat => cfg%contact%dhat
    contact_stiffness => cfg%contact%stiffness; friction_eps_v => cfg%contact%eps_v
    contact_faces => cfg%contact%faces; self_contact => cfg%contact%self_contact; self_mu => cfg%contact%self_mu
    self_step => cfg%contact%self_step
    obstacle_half_size => cfg%contact%half_size; obstacle_axis => cfg%contact%axis; obstacle_end => cfg%contact%end_pt
    obstacle_n_keyframes => cfg%contact%n_keyframes; obstacle_time => cfg%contact%key_time
    obstacle_offset => cfg%contact%key_offset; obstacle_close => cfg%contact%key_close
    obstacle_close_dir => cfg%contact%close_dir
    ios = 0
    if (mode == NML_WRITE) then
      call write_group()
    else
      call read_group()
    end if
    ! gfortran may report an end of file with iostat < 0: the group is known
    ! to be present and closed, so any non-zero status is an error.
    if (ios /= 0) then
      if (len_trim(iomsg) == 0) iomsg = 'read error'
      call reset_list_state()
    end if

  contains

    subroutine read_group()
      select case (g)
      case (G_LATTICE);  read(lines, nml=lattice, iostat=ios, iomsg=iomsg)
      case (G_MATERIAL); read(lines, nml=material, iostat=ios, iomsg=iomsg)
      case (G_SCENE);    read(lines, nml=scene, iostat=ios, iomsg=iomsg)
      case (G_TIME);     read(lines, nml=time, iostat=ios, iomsg=iomsg)
      case (G_OUTPUT);   read(lines, nml=output, iostat=ios, iomsg=iomsg)
      case (G_IDENTIFY); read(lines, nml=identify, iostat=ios, iomsg=iomsg)
      case (G_CONTROL);  read(lines, nml=control, iostat=ios, iomsg=iomsg)
      case (G_CONTACT);  read(lines, nml=contact, iostat=ios, iomsg=iomsg)
      end select
    end subroutine read_group

    subroutine write_group()
      select case (g)
      case (G_LATTICE);  write(records, nml=lattice, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_MATERIAL); write(records, nml=material, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_SCENE);    write(records, nml=scene, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_TIME);     write(records, nml=time, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_OUTPUT);   write(records, nml=output, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_IDENTIFY); write(records, nml=identify, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_CONTROL);  write(records, nml=control, delim='apostrophe', iostat=ios, iomsg=iomsg)
      case (G_CONTACT);  write(records, nml=contact, delim='apostrophe', iostat=ios, iomsg=iomsg)
      end select
    end subroutine write_group

  end subroutine namelist_transfer

  !> libgfortran 12 keeps state after a failed namelist read (e.g. a bad
  !> logical: 'Bad repeat count'), and the next namelist read then succeeds
  !> wrongly; any list-directed read clears it.
  subroutine reset_list_state()
    character(1) :: one
    integer :: i, ios
    one = '0'
    read(one, *, iostat=ios) i
  end subroutine reset_list_state

end module input_namelist
