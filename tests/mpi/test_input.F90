! SPDX-License-Identifier: BSD-2-Clause
!> Tests of module input: defaults and scene defaults, overrides, the energy
!> k_b conversion, the files in input/, and bad inputs that must fail on every
!> rank with a message naming the key. Run on 1 and 3 ranks.
program test_input
  use mpi
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use config
  use input, only: input_read, input_summary
  use input_usage, only: usage_text
  use check, only: check_true, check_close, check_close_array, check_report
  implicit none
  integer :: rank, mpierr, u
  type(nuno_config) :: cfg, ref
  character(1024) :: msg
  character(:), allocatable :: root
  integer :: ierr
  real(rp), parameter :: tol = 1.0e-14_rp
  character(*), parameter :: nl = new_line('a')

  call MPI_Init(mpierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, mpierr)
  root = source_root()

  ! ---- defaults: an input with one empty group is lift_release --------------
  call read_text('! nothing here'//nl//'&scene /'//nl, cfg, ierr, msg)
  call expect_ok('empty input')
  call check_true(trim(cfg%scene%name) == 'lift_release' .and. cfg%scene%scene_code == SCENE_LIFT_RELEASE, 'default scene')
  call check_true(cfg%lattice%nx == 11 .and. cfg%lattice%ny == 11, 'default nx, ny')
  call check_close(cfg%lattice%lx, 100.0_rp, tol, 0.0_rp, 'default lx')
  call check_close(cfg%lattice%ax, 10.0_rp, tol, 0.0_rp, 'ax = lx/(nx-1)')
  call check_close(cfg%lattice%ay, 10.0_rp, tol, 0.0_rp, 'ay = ly/(ny-1)')
  call check_close(cfg%lattice%total_mass, 1.0_rp, tol, 0.0_rp, 'default total_mass')
  call check_true(cfg%lattice%mass_code == MASS_UNIFORM .and. cfg%lattice%scaling_code == SCALING_ELEMENT, 'default mass, scaling')
  call check_true(cfg%material%spring_code == SPRING_AXIAL .and. cfg%material%bending_code == BEND_PAPER, 'default models')
  call check_close(cfg%material%k_b, 1.0_rp, tol, 0.0_rp, 'lift_release paper k_b')
  call check_close(cfg%material%eta_b, 0.0_rp, tol, 0.0_rp, 'lift_release eta_b')
  call check_close(cfg%material%e_s, 1.0_rp, tol, 0.0_rp, 'report E')
  call check_close(cfg%material%eta_d, 1.0_rp, tol, 0.0_rp, 'report eta')
  call check_true(.not. cfg%scene%has_gravity .and. cfg%material%has_damping, 'has_gravity, has_damping')
  call check_close(cfg%time%t_end, 5.0_rp, tol, 0.0_rp, 'lift_release t_end')
  call check_close(cfg%time%dt, 1.0e-3_rp, tol, 0.0_rp, 'lift_release dt')
  call check_true(trim(cfg%output%output_file) == 'lift_release.h5', 'lift_release output_file')
  call check_true(allocated(cfg%namelist_text), 'namelist_text kept')
  if (allocated(cfg%namelist_text)) &
    call check_true(cfg%namelist_text == '! nothing here'//nl//'&scene /'//nl, 'namelist_text = file')

  ! ---- hang: SI scene defaults -----------------------------------------------
  call read_text("&scene scene = 'hang' /", cfg, ierr, msg)
  call expect_ok('hang')
  call check_true(cfg%scene%scene_code == SCENE_HANG .and. cfg%lattice%nx == 21 .and. cfg%lattice%ny == 21, 'hang lattice')
  call check_close(cfg%lattice%lx, 1.0_rp, tol, 0.0_rp, 'hang lx')
  call check_close(cfg%lattice%total_mass, 0.1_rp, tol, 0.0_rp, 'hang mass')
  call check_true(cfg%lattice%mass_code == MASS_AREA .and. cfg%material%bending_code == BEND_ENERGY, 'hang area masses, energy')
  call check_close(cfg%material%e_s, 100.0_rp, tol, 0.0_rp, 'hang E_s')
  call check_close(cfg%material%eta_d, 0.1_rp, tol, 0.0_rp, 'hang eta_d')
  call check_close(cfg%material%k_b, 0.1_rp, tol, 0.0_rp, 'hang k_b')
  call check_close(cfg%material%eta_b, 1.0e-4_rp, tol, 0.0_rp, 'hang eta_b')
  call check_close_array(cfg%scene%gravity, [0.0_rp, 0.0_rp, -9.81_rp], tol, 0.0_rp, 'hang gravity')
  call check_true(cfg%scene%has_gravity, 'hang has_gravity')
  call check_close(cfg%time%t_end, 2.0_rp, tol, 0.0_rp, 'hang t_end')
  call check_close(cfg%output%output_interval, 0.05_rp, tol, 0.0_rp, 'hang output_interval')

  ! ---- other scenes ----------------------------------------------------------
  call read_text("&scene scene = 'bend_release' /", cfg, ierr, msg)
  call expect_ok('bend_release')
  call check_close(cfg%lattice%lx, 50.0_rp, tol, 0.0_rp, 'bend_release lx')
  call check_close(cfg%lattice%total_mass, 0.25_rp, tol, 0.0_rp, 'bend_release mass')
  call check_close(cfg%scene%bend_angle, 30.0_rp, tol, 0.0_rp, 'bend_release bend_angle')
  call read_text("&scene scene = 'wave_point' /", cfg, ierr, msg)
  call expect_ok('wave_point')
  call check_true(cfg%material%bending_code == BEND_NONE .and. cfg%scene%n_keyframes == 3, 'wave_point: no bending, 3 keyframes')
  call check_close_array(cfg%scene%keyframe_time(1:3), [0.0_rp, 0.5_rp, 1.0_rp], tol, 0.0_rp, 'wave_point keyframe_time')
  call check_close_array(cfg%scene%keyframe_dz(1:3), [0.0_rp, -10.0_rp, 15.0_rp], tol, 0.0_rp, 'wave_point keyframe_dz')
  call read_text("&scene scene = 'FLAT' /", cfg, ierr, msg)
  call expect_ok('flat (upper case)')
  call check_true(cfg%scene%scene_code == SCENE_FLAT .and. trim(cfg%scene%name) == 'flat', 'flat scene, lower-cased')

  ! ---- values set in the file override; comments, &end, subscripts ------------
  call read_text( &
    '! a comment with &lattice nx = 5 / in it'//nl// &
    ' &LATTICE nx = 21, ! comment: &material'//nl// &
    '   ly = 50.0 /'//nl// &
    '! a comment between groups'//nl// &
    "&material bending_model = 'Energy' /"//nl// &
    "&scene keyframe_time(2) = 0.6 gravity = 0 0 -1 /"//nl// &
    "&output output_file = 'a!b&c/d.h5', petsc_options = '-ts_type bdf' &end"//nl// &
    '&time dt = 0.01 /', cfg, ierr, msg)
  call expect_ok('overrides')
  call check_true(cfg%lattice%nx == 21 .and. cfg%lattice%ny == 11, 'nx from the file, ny default')
  call check_close(cfg%lattice%ax, 5.0_rp, tol, 0.0_rp, 'ax at nx = 21')
  call check_close(cfg%lattice%ay, 5.0_rp, tol, 0.0_rp, 'ay at ly = 50')
  call check_true(cfg%material%bending_code == BEND_ENERGY, 'bending_model energy (case-insensitive)')
  call check_close(cfg%material%k_b, 5.0_rp, tol, 0.0_rp, 'energy k_b = 1 * ax at nx = 21')
  call check_close(cfg%scene%keyframe_time(2), 0.6_rp, tol, 0.0_rp, 'keyframe_time(2) set')
  call check_close(cfg%scene%keyframe_time(3), 1.0_rp, tol, 0.0_rp, 'keyframe_time(3) default')
  call check_true(cfg%scene%has_gravity, 'gravity set')
  call check_true(trim(cfg%output%output_file) == 'a!b&c/d.h5', 'string with ! & / kept')
  call check_true(trim(cfg%output%petsc_options) == '-ts_type bdf', 'petsc_options')
  call check_close(cfg%time%dt, 0.01_rp, tol, 0.0_rp, 'dt set')
  call check_close(cfg%time%t_end, 5.0_rp, tol, 0.0_rp, 't_end default')

  ! ---- the energy k_b conversion; a k_b that the user sets is used as given -----
  call read_text("&material bending_model = 'energy' /", cfg, ierr, msg)
  call expect_ok('lift_release energy')
  call check_close(cfg%material%k_b, 10.0_rp, tol, 0.0_rp, 'lift_release energy k_b = 1 * 10')
  call check_close(cfg%material%eta_b, 0.0_rp, tol, 0.0_rp, 'lift_release energy eta_b = 0')
  call read_text("&scene scene = 'wave_point' / &material bending_model = 'energy' /", cfg, ierr, msg)
  call expect_ok('wave_point energy')
  call check_close(cfg%material%k_b, 10.0_rp, tol, 0.0_rp, 'wave_point energy k_b')
  call read_text("&material bending_model = 'energy', k_b = 3.5, eta_b = 0.25 /", cfg, ierr, msg)
  call expect_ok('k_b set')
  call check_close(cfg%material%k_b, 3.5_rp, tol, 0.0_rp, 'k_b as given')
  call check_close(cfg%material%eta_b, 0.25_rp, tol, 0.0_rp, 'eta_b as given')
  call read_text("&scene scene='hang' / &lattice lattice_scaling='continuum' /", cfg, ierr, msg)
  call expect_ok('hang continuum')
  call check_true(cfg%lattice%scaling_code == SCALING_CONTINUUM .and. cfg%lattice%mass_code == MASS_AREA, 'continuum + area')

  ! ---- the files in input/ ---------------------------------------------------
  call read_file(root//'input/lift_release.nml', cfg, ierr, msg)
  call expect_ok('input/lift_release.nml')
  call read_text("&scene scene = 'lift_release' /", ref, ierr, msg)
  call check_same(cfg, ref, 'lift_release.nml = scene defaults')
  call read_file(root//'input/lift_release_energy.nml', cfg, ierr, msg)
  call expect_ok('input/lift_release_energy.nml')
  call read_text("&material bending_model = 'energy' /", ref, ierr, msg)
  call check_same(cfg, ref, 'lift_release_energy.nml = defaults with energy')
  call read_file(root//'input/bend_release.nml', cfg, ierr, msg)
  call expect_ok('input/bend_release.nml')
  call read_text("&scene scene = 'bend_release' /", ref, ierr, msg)
  call check_same(cfg, ref, 'bend_release.nml = scene defaults')
  call read_file(root//'input/bend_release_energy.nml', cfg, ierr, msg)
  call expect_ok('input/bend_release_energy.nml')
  call check_close(cfg%material%k_b, 5.0_rp, tol, 0.0_rp, 'bend_release energy k_b = 1 * 5')
  call read_text("&scene scene = 'bend_release' / &material bending_model = 'energy' /", ref, ierr, msg)
  call check_same(cfg, ref, 'bend_release_energy.nml = defaults with energy')
  call read_file(root//'input/wave_point.nml', cfg, ierr, msg)
  call expect_ok('input/wave_point.nml')
  call read_text("&scene scene = 'wave_point' /", ref, ierr, msg)
  call check_same(cfg, ref, 'wave_point.nml = scene defaults')
  call read_file(root//'input/wave_point_energy.nml', cfg, ierr, msg)
  call expect_ok('input/wave_point_energy.nml')
  call read_text("&scene scene = 'wave_point' / &material bending_model = 'energy' /", ref, ierr, msg)
  call check_same(cfg, ref, 'wave_point_energy.nml = defaults with energy')
  call read_file(root//'input/hang.nml', cfg, ierr, msg)
  call expect_ok('input/hang.nml')
  call read_text("&scene scene = 'hang' /", ref, ierr, msg)
  call check_same(cfg, ref, 'hang.nml = scene defaults')

  ! ---- bad inputs: ierr /= 0 on every rank, the message names the key --------
  call expect_error('&lattice nz = 3 /', [character(60) :: '&lattice', 'nz'])
  call expect_error("&lattice nx = 'abc' /", [character(60) :: '&lattice', 'nx'])
  call expect_error('&lattice nx = 3.5 /', [character(60) :: '&lattice', 'nx'])
  call expect_error('&lattice nx = 2 /', [character(60) :: 'nx = 2 must be >= 3'])
  call expect_error('&lattice ny = 1 /', [character(60) :: 'ny = 1'])
  call expect_error('&lattice total_mass = -1 /', [character(60) :: '&lattice', 'total_mass'])
  call expect_error('&lattice lx = 0 /', [character(60) :: 'lx = 0.0'])
  call expect_error("&scene scene = 'foo' /", [character(60) :: '&scene', 'scene', 'foo'])
  call expect_error("&scene scene = 3 4 /", [character(60) :: '&scene', 'scene'])
  call expect_error("&material spring_model = 'foo' /", [character(60) :: "spring_model = 'foo' is not one of axial, linear"])
  call expect_error("&material bending_model = 'bar' /", [character(60) :: 'bending_model'])
  call expect_error("&lattice mass_distribution = 'x' /", [character(60) :: 'mass_distribution'])
  call expect_error("&lattice lattice_scaling = 'continuum' /", [character(60) :: 'continuum', 'paper', 'bending_model'])
  call expect_error("&lattice lattice_scaling = 'continuum', mass_distribution = 'uniform' / " // &
                    "&material bending_model = 'energy' /", ['mass_distribution'])
  call expect_error('&material e_s = -1 /', [character(60) :: 'e_s'])
  call expect_error('&material k_b = -2 /', [character(60) :: 'k_b'])
  call expect_error('&material eta_b = -2 /', [character(60) :: 'eta_b'])
  call expect_error('&time dt = 0 /', [character(60) :: '&time', 'dt'])
  call expect_error('&time t_end = -1 /', [character(60) :: 't_end'])
  call expect_error('&output output_interval = 0 /', [character(60) :: 'output_interval'])
  call expect_error("&output output_file = '' /", [character(60) :: 'output_file'])
  call expect_error('&output write_velocity = 7 /', [character(60) :: 'write_velocity'])
  call expect_error('&scene n_keyframes = 0 /', [character(60) :: 'n_keyframes'])
  call expect_error('&scene n_keyframes = 33 /', [character(60) :: 'n_keyframes'])
  call expect_error('&scene keyframe_time = 0 0.5 0.5 /', [character(60) :: 'keyframe_time(3)'])
  call expect_error('&scene lift_length = 200 /', [character(60) :: 'lift_length'])
  call expect_error('&scene lift_height = 40 /', [character(60) :: 'lift_height'])
  call expect_error("&scene scene = 'bend_release', bend_angle = 400 /", [character(60) :: 'bend_angle'])
  call expect_error('&lattice nx = 5 / &lattice ny = 5 /', [character(60) :: '&lattice', 'again'])
  call expect_error('&lattcie nx = 5 /', [character(60) :: '&lattcie'])
  call expect_error('&lattice nx = 5 '//nl//'&time dt = 1 /', [character(60) :: '&lattice', 'closing'])
  call expect_error('&lattice nx = 5', [character(60) :: '&lattice', 'closing'])
  call expect_error("&output output_file = 'x.h5 /", [character(60) :: 'unterminated'])
  ! Input that cannot be mistaken (issue 8): no silent defaults, no NaN/Inf.
  call expect_error('', [character(60) :: 'empty'])
  call expect_error('  '//nl//nl, [character(60) :: 'empty'])
  call expect_error('! only a comment'//nl, [character(60) :: 'no namelist group'])
  call expect_error('&time dt = 0.01 /'//nl//nl//'stray words'//nl, [character(60) :: 'line 3', 'stray words'])
  call expect_error('&time dt = 0.01 / trailing', [character(60) :: 'line 1', 'trailing'])
  call expect_error(achar(0)//achar(255)//'xyz', [character(60) :: 'line 1', 'outside'])
  call expect_error('&scene gravity = 0 0 NaN /', [character(60) :: 'gravity(3) = NaN', 'finite'])
  call expect_error('&scene initial_omega = 0 Inf 0 /', [character(60) :: 'initial_omega(2) = +Infinity'])
  call expect_error('&scene keyframe_dz(2) = -Inf /', [character(60) :: 'keyframe_dz(2) = -Infinity'])
  call expect_error('&scene release_time = Inf /', [character(60) :: 'release_time', 'finite'])
  call expect_error('&material e_s = Inf /', [character(60) :: 'e_s = +Infinity'])
  call expect_error('&time dt = NaN /', [character(60) :: '&time', 'dt = NaN'])
  call read_file('no_such_dir/no_such_file.nml', cfg, ierr, msg)
  call expect_collective_error('missing file', [character(60) :: 'cannot open input file', 'no_such_file.nml'])

  ! ---- help and summary write without trouble --------------------------------
  ! (read_text is collective: the reads stay outside the rank-0 block)
  open(newunit=u, status='scratch', action='readwrite')
  call usage_text(u)
  call read_text("&scene scene = 'wave_point' /", cfg, ierr, msg)
  call input_summary(cfg, u, 0.0_rp, .false., 0.0_rp, .false.)
  call read_text("&scene scene = 'hang' / &output write_velocity = .true. /", cfg, ierr, msg)
  call input_summary(cfg, u, 0.0_rp, .false., 0.0_rp, .false.)
  call check_true(count_lines(u) > 20, 'usage and summaries written')
  if (rank == 0) then
    call usage_text(output_unit)
    call input_summary(cfg, output_unit, 0.0_rp, .false., 0.0_rp, .false.)
  end if
  close(u)

  call check_report()
  call MPI_Finalize(mpierr)

contains

  !> Repository root from this file's path (CMake compiles it by absolute path).
  function source_root() result(r)
    character(:), allocatable :: r
    character(*), parameter :: me = __FILE__
    integer :: p
    p = index(me, 'tests/mpi/test_input.F90', back=.true.)
    r = ''
    if (p > 1) r = me(1:p - 1)
  end function source_root

  !> Write text to a file on rank 0 and read it through input_read on all ranks.
  subroutine read_text(text, cfg, ierr, msg)
    character(*), intent(in) :: text
    type(nuno_config), intent(out) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    character(*), parameter :: path = 'test_input_scratch.nml'
    integer :: u, merr
    if (rank == 0) then
      open(newunit=u, file=path, access='stream', form='unformatted', status='replace', action='write')
      write(u) text
      close(u)
    end if
    call MPI_Barrier(MPI_COMM_WORLD, merr)
    call input_read(path, MPI_COMM_WORLD, '', 0, cfg, ierr, msg)
    ! Nobody rewrites the file before every rank has read it.
    call MPI_Barrier(MPI_COMM_WORLD, merr)
  end subroutine read_text

  subroutine read_file(path, cfg, ierr, msg)
    character(*), intent(in) :: path
    type(nuno_config), intent(out) :: cfg
    integer, intent(out) :: ierr
    character(*), intent(out) :: msg
    call input_read(path, MPI_COMM_WORLD, '', 0, cfg, ierr, msg)
  end subroutine read_file

  subroutine expect_ok(what)
    character(*), intent(in) :: what
    call check_true(ierr == 0, what//': ierr = 0 (got: '//trim(msg)//')')
  end subroutine expect_ok

  !> text must fail on every rank, with every one of `words` in the message.
  subroutine expect_error(text, words)
    character(*), intent(in) :: text
    character(*), intent(in) :: words(:)
    call read_text(text, cfg, ierr, msg)
    call expect_collective_error(text, words)
  end subroutine expect_error

  subroutine expect_collective_error(what, words)
    character(*), intent(in) :: what
    character(*), intent(in) :: words(:)
    integer :: failed, all_failed, merr, k
    failed = merge(1, 0, ierr /= 0)
    call MPI_Allreduce(failed, all_failed, 1, MPI_INTEGER, MPI_MIN, MPI_COMM_WORLD, merr)
    call check_true(all_failed == 1, 'error on every rank: '//what)
    do k = 1, size(words)
      call check_true(index(msg, trim(words(k))) > 0, 'message of ['//what//'] names "'// &
                      trim(words(k))//'": '//trim(msg))
    end do
    call check_true(index(trim(msg), new_line('a')) == 0 .and. msg(1:6) == 'input:', &
                    'one-line message starting input: ['//trim(msg)//']')
  end subroutine expect_collective_error

  !> The keys that a scene file writes out match the scene's defaults.
  subroutine check_same(a, b, what)
    type(nuno_config), intent(in) :: a, b
    character(*), intent(in) :: what
    logical :: same
    same = a%lattice%nx == b%lattice%nx .and. a%lattice%ny == b%lattice%ny .and. a%lattice%lx == b%lattice%lx .and. a%lattice%ly == b%lattice%ly .and. &
      a%lattice%total_mass == b%lattice%total_mass .and. a%lattice%mass_code == b%lattice%mass_code .and. a%lattice%scaling_code == b%lattice%scaling_code .and. &
      a%material%spring_code == b%material%spring_code .and. a%material%e_s == b%material%e_s .and. a%material%eta_s == b%material%eta_s .and. &
      a%material%e_d == b%material%e_d .and. a%material%eta_d == b%material%eta_d .and. a%material%bending_code == b%material%bending_code .and. &
      a%material%k_b == b%material%k_b .and. a%material%eta_b == b%material%eta_b .and. a%scene%scene_code == b%scene%scene_code .and. &
      all(a%scene%gravity == b%scene%gravity) .and. a%scene%lift_length == b%scene%lift_length .and. &
      a%scene%lift_height == b%scene%lift_height .and. a%scene%bend_angle == b%scene%bend_angle .and. &
      a%scene%n_keyframes == b%scene%n_keyframes .and. all(a%scene%keyframe_time == b%scene%keyframe_time) .and. &
      all(a%scene%keyframe_dz == b%scene%keyframe_dz) .and. a%scene%release_time == b%scene%release_time .and. &
      all(a%scene%initial_omega == b%scene%initial_omega) .and. a%time%t_end == b%time%t_end .and. a%time%dt == b%time%dt .and. &
      a%output%output_interval == b%output%output_interval .and. (a%output%write_velocity .eqv. b%output%write_velocity) .and. &
      (a%scene%has_gravity .eqv. b%scene%has_gravity)
    call check_true(same, what)
  end subroutine check_same

  integer function count_lines(u) result(n)
    integer, intent(in) :: u
    character(256) :: line
    integer :: ios
    rewind(u)
    n = 0
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      n = n + 1
    end do
  end function count_lines

end program test_input
