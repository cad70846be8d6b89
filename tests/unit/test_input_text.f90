! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of module input_text without MPI or PETSc: the -nuno_set lexer
!> (commas or blanks between keys, several options in order, empty values,
!> '/', unknown keys, keys given twice), the check of a value against its
!> key's type, the key table and the record of the options, a key's default
!> in a scene, a value read back from a namelist WRITE.
program test_input_text
  use input_text, only: assignment_t, lex_overrides, value_error, key_lookup, overrides_record, &
                        KEY_INTEGER, KEY_REAL, KEY_LOGICAL, KEY_STRING, key_default, namelist_value, &
                        item_end, assignment_lhs
  use input_keys, only: key_index
  use check, only: check_true, check_report
  implicit none
  character(1), parameter :: lf = achar(10)
  character(8) :: group
  integer :: kind
  logical :: array

  ! ---- keys separated by commas or blanks: the same assignments --------
  call expect_items('nx=13 ny=13', [character(16) :: 'nx', 'ny'], [character(16) :: '13', '13'])
  call expect_items('nx=13,ny=13', [character(16) :: 'nx', 'ny'], [character(16) :: '13', '13'])
  call expect_items(' , nx = 13 ,, ny=13 , ', [character(16) :: 'nx', 'ny'], [character(16) :: '13', '13'])
  ! An array's values may be separated by blanks or commas too.
  call expect_items('gravity=0 0 -9.81, nx=7', [character(16) :: 'gravity', 'nx'], &
                    [character(16) :: '0 0 -9.81', '7'])
  call expect_items('gravity=0,0,-9.81 nx=7', [character(16) :: 'gravity', 'nx'], &
                    [character(16) :: '0,0,-9.81', '7'])
  ! A string keeps its commas, blanks and '=' (and a doubled quote).
  call expect_items("output_file='a, b=c.h5' nx=3", [character(16) :: 'output_file', 'nx'], &
                    [character(16) :: "'a, b=c.h5'", '3'])
  call expect_items("fit='it''s' tikhonov=0", [character(16) :: 'fit', 'tikhonov'], &
                    [character(16) :: "'it''s'", '0'])
  ! group%key and subscripts; the key is lower case without blanks.
  call expect_items('TIME%DT=1e-3, keyframe_time( 2 )=0.6', [character(16) :: 'dt', 'keyframe_time(2)'], &
                    [character(16) :: '1e-3', '0.6'])
  ! Several -nuno_set options (joined by line feeds): read in order.
  call expect_items('nx=33'//lf//'ny=33', [character(16) :: 'nx', 'ny'], [character(16) :: '33', '33'])
  call expect_items("scene='hang'"//lf//'nx=5 ny=7'//lf//'dt=1e-3', &
                    [character(16) :: 'scene', 'nx', 'ny', 'dt'], [character(16) :: "'hang'", '5', '7', '1e-3'])

  ! ---- refused, each by name --------------------------------------------
  call expect_error('nx=', 'nx has no value')
  call expect_error('nx=,ny=5', 'nx has no value')
  call expect_error('nx=5 ny=', 'ny has no value')
  call expect_error('', 'no value')
  call expect_error('nx=5'//lf//'', 'no value')
  call expect_error('nx=7 / ny=9', "'/'")
  call expect_error('nx=7 ! ny=9', "'!'")
  call expect_error('nx=7,nx=9', 'nx is given twice')
  call expect_error('nx=7 lattice%nx=9', 'nx is given twice')
  call expect_error('nx=7'//lf//'nx=9', 'nx is given twice')
  call expect_error('gravity=0,0,-9 gravity(3)=1', 'gravity(3) is given twice')
  call expect_error('keyframe_time(2)=1 keyframe_time(2)=2', 'keyframe_time(2) is given twice')
  call expect_error('nz=3', "unknown key 'nz'")
  call expect_error('lattice%dt=1', 'dt is a key of &time')
  call expect_error('nx(2)=3', 'nx is not an array')
  call expect_error('257', 'expected key=value')
  call expect_error('nx 5', 'expected key=value')
  call expect_error('foo nx=5', "'foo' is not key=value")
  call expect_error('nx=33.5', 'nx=33.5: expected an integer')
  call expect_error('nx=5 7', 'expected one integer')
  call expect_error('e_s=abc', 'e_s=abc: expected a real number')
  call expect_error('write_velocity=3', 'expected a logical')
  call expect_error('output_file=foo.h5', "-nuno_set ""output_file='foo.h5'""")
  call expect_error("output_file='foo.h5", 'unterminated string')

  ! ---- a value against its key's type ----------------------------------
  call check_true(value_error('nx', '5') == '', 'nx = 5')
  call check_true(value_error('nx', '-5') == '', 'nx = -5 (range checked later)')
  call check_true(value_error('nx', '33.5') == 'expected an integer', 'nx = 33.5')
  call check_true(value_error('nx', '2*3') /= '', 'nx = 2*3: a repeat count on a scalar')
  call check_true(value_error('e_s', '1') == '', 'e_s = 1')
  call check_true(value_error('e_s', '1d-3') == '', 'e_s = 1d-3')
  call check_true(value_error('e_s', '.5E+2') == '', 'e_s = .5E+2')
  call check_true(value_error('e_s', '-2.') == '', 'e_s = -2.')
  call check_true(value_error('e_s', 'NaN') == '', 'e_s = NaN (lexically a real; the finiteness check names it)')
  call check_true(value_error('e_s', '-Inf') == '', 'e_s = -Inf')
  call check_true(value_error('e_s', '1e') == 'expected a real number', 'e_s = 1e')
  call check_true(value_error('e_s', '1.2.3') /= '', 'e_s = 1.2.3')
  call check_true(value_error('e_s', "'1'") /= '', "e_s = '1'")
  call check_true(value_error('write_velocity', '.TRUE.') == '', 'write_velocity = .TRUE.')
  call check_true(value_error('write_velocity', 'f') == '', 'write_velocity = f')
  call check_true(value_error('write_velocity', 'yes') /= '', 'write_velocity = yes')
  call check_true(value_error('gravity', '3*0.0') == '', 'gravity = 3*0.0')
  call check_true(value_error('gravity', '0, 0, -9.81') == '', 'gravity = 0, 0, -9.81')
  call check_true(value_error('gravity(3)', '-9.81') == '', 'gravity(3) = -9.81')
  call check_true(value_error('gravity', '0, x, 1') == 'expected a real number', 'gravity = 0, x, 1')
  call check_true(value_error('fit', "'e_s, e_d'") == '', "fit = 'e_s, e_d'")
  call check_true(index(value_error('output_file', 'foo.h5'), "output_file='foo.h5'") > 0, &
                  'output_file = foo.h5: the hint quotes it')
  call check_true(index(value_error('fit', "'e_s' 'e_d'"), 'expected one quoted string') > 0, &
                  "fit = 'e_s' 'e_d': one string")
  call check_true(value_error('output_file', "'a/b.h5'") == '', "output_file = 'a/b.h5' ('/' in a string)")
  call check_true(value_error('no_such_key', 'x') == '', 'an unknown key: no type to check')

  ! ---- the key table ------------------------------------------------------
  call key_lookup('nx', group, kind, array)
  call check_true(group == 'lattice' .and. kind == KEY_INTEGER .and. .not. array, 'nx: &lattice, integer')
  call key_lookup('gravity', group, kind, array)
  call check_true(group == 'scene' .and. kind == KEY_REAL .and. array, 'gravity: &scene, real array')
  call key_lookup('write_velocity', group, kind, array)
  call check_true(group == 'output' .and. kind == KEY_LOGICAL, 'write_velocity: &output, logical')
  call key_lookup('target_file', group, kind, array)
  call check_true(group == 'control' .and. kind == KEY_STRING, 'target_file: &control, string')
  call key_lookup('nz', group, kind, array)
  call check_true(group == '' .and. kind == 0, 'nz: no such key')

  ! ---- the record in the output's namelist text --------------------------
  call check_true(overrides_record('nx=7,ny=6') == '-nuno_set nx=7,ny=6', 'one option recorded as given')
  call check_true(overrides_record('nx=7'//lf//'ny=9') == '-nuno_set nx=7 -nuno_set ny=9', 'two options recorded')
  call check_true(overrides_record('nx=7'//lf) == '-nuno_set nx=7 -nuno_set ', 'an empty last option recorded')
  call check_true(overrides_record('') == '-nuno_set ', 'an empty option recorded')

  ! ---- the walk of a separated list and an assignment's key ------------
  call check_true(item_end('a, b, c', 1, ', ') == 2, 'the first separator')
  call check_true(item_end('a, b, c', 3, ', ') == 5, 'a separator after from')
  call check_true(item_end('a, b, c', 6, ', ') == 8, 'none left: len + 1')
  call check_true(item_end('abc', 4, ',') == 4, 'from past the end: len + 1')
  call check_true(assignment_lhs(' Gravity( 3 ) = 1, 2') == 'gravity(3)', 'the key in lower case without blanks')
  call check_true(assignment_lhs('no assignment') == '', 'no = : no key')

  ! ---- the table's default of a key in a scene, in namelist syntax -----
  call check_true(key_default(key_index('lx'), 'lift_release') == '100', 'lx default')
  call check_true(key_default(key_index('lx'), 'bend_release') == '50', 'lx in bend_release')
  call check_true(key_default(key_index('lx'), 'hang') == '1', 'lx in hang')
  call check_true(key_default(key_index('gravity'), 'hang') == '0, 0, -9.81', 'gravity in hang: no parentheses')
  call check_true(key_default(key_index('gravity'), 'flat') == '0, 0, 0', 'gravity in flat')
  call check_true(key_default(key_index('output_file'), 'flat') == "'flat.h5'", 'output_file: <scene>')
  call check_true(key_default(key_index('bending_model'), 'wave_point') == "'none'", 'bending_model in wave_point')
  call check_true(key_default(key_index('k_b'), 'hang') == '', 'k_b: a description, no value')
  call check_true(key_default(key_index('release_time'), 'flat') == '', 'release_time: never, no value')
  call check_true(key_default(key_index('observed_file'), 'flat') == '', 'observed_file: required, no value')

  ! ---- a value read back from a namelist WRITE ---------------------------
  block
    character(*), parameter :: dump = '&SCENE'//lf//' SCENE_NAME=''hang'','//lf// &
      ' GRAVITY= 2*0.0000000000000000 ,'//lf//' -9.8100000000000005 ,'//lf//' LIFT_LENGTH=  30.0 ,'//lf//' /'//lf
    call check_true(namelist_value(dump, 'gravity') == '2*0.0000000000000000 , -9.8100000000000005 ,', &
                    'an array over two records')
    call check_true(namelist_value(dump, 'lift_length') == '30.0 ,', 'the last key before /')
    call check_true(namelist_value(dump, 'scene_name') == "'hang',", 'a string')
    call check_true(namelist_value(dump, 'lift') == '', 'no such key')
  end block

  call check_report()

contains

  subroutine expect_items(ov, keys, values)
    character(*), intent(in) :: ov
    character(*), intent(in) :: keys(:), values(:)
    type(assignment_t), allocatable :: items(:)
    character(:), allocatable :: msg
    integer :: ierr, k
    logical :: ok
    call lex_overrides(ov, items, ierr, msg)
    ok = ierr == 0
    if (ok) ok = size(items) == size(keys)
    if (ok) then
      do k = 1, size(keys)
        ok = ok .and. items(k)%key == trim(keys(k)) .and. items(k)%value == trim(values(k))
      end do
    end if
    call check_true(ok, 'lex: '//ov//' ['//msg//']')
  end subroutine expect_items

  subroutine expect_error(ov, words)
    character(*), intent(in) :: ov, words
    type(assignment_t), allocatable :: items(:)
    character(:), allocatable :: msg
    integer :: ierr
    call lex_overrides(ov, items, ierr, msg)
    call check_true(ierr /= 0 .and. index(msg, words) > 0 .and. index(msg, 'input: -nuno_set') == 1, &
                    'refused: '//ov//' -> '//msg//' (expected: '//words//')')
  end subroutine expect_error
end program test_input_text
