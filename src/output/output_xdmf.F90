! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the XDMF sidecars that ParaView and VTK (pyvista) read:
!> <file>.xdmf (the cloth) and, in a scene with obstacles,
!> <file>-obstacles.xdmf (the obstacles).
submodule (output) output_xdmf
  implicit none

  character(len=*), parameter :: F8 = 'NumberType="Float" Precision="8"'
  character(len=*), parameter :: I4 = 'NumberType="Int" Precision="4"'

  !> A sidecar being written (rank 0, plain Fortran I/O, rewritten whole
  !> at each step): written whole into a new file made exclusively beside
  !> it, then renamed onto the name: never through a symbolic link, never
  !> half-written. Lines are gathered in buf for one write(2).
  type :: xml_file
    integer :: u = -1, nbuf = 0
    logical :: good = .false.
    character(len=:), allocatable :: path, tmp, h5   ! the sidecar, its new file, the HDF5 file's name in XML text
    character(len=:), allocatable :: buf             ! BUF_LEN characters
  end type xml_file

  integer, parameter :: BUF_LEN = 65536

contains

  ! ---------------------------------------------------------------------------
  ! XDMF sidecar (rank 0, plain Fortran I/O, rewritten whole at each step).

  ! Layout, checked with ParaView 5.11's three XDMF readers (the legacy
  ! "XDMF Reader" on Xdmf2, and Xdmf3ReaderS/T) by tests/python/test_xdmf.py
  ! and with VTK 9's vtkXdmfReader (pyvista) by tests/python/test_readers.py:
  ! a temporal collection of n_output_steps uniform grids, each a 3DSMesh of
  ! Dimensions "1 ny nx" (one layer of ny x nx points: VTK dimensions
  ! (nx, ny, 1), point j*nx + i), XYZ geometry /xdmf/position_<k>, and the
  ! point data
  !   velocity       /xdmf/velocity_<k> (when written)
  !   rest_position  /xdmf/rest_position
  !   mass           /xdmf/mass
  !   displacement   Function "$0 - $1" of /xdmf/position_<k> and
  !                  /lattice/rest_position (legacy reader only)
  ! Each is a plain HDF DataItem of a virtual dataset (lattice_views,
  ! make_view) shaped like the topology (+ 3 for vectors): the legacy reader
  ! selects the point range of a structured grid on it (not 2DSMesh
  ! "ny nx": with it that selection goes wrong for vector point data). The
  ! Xdmf3 readers read no HyperSlab or Function item (the item's number
  ! type is unknown to them before it is read): they skip displacement with
  ! one line "Skipping unrecognized array type [None]" per step and load
  ! everything else; Calculator "coords - rest_position" gives it there.
  ! No view is needed by the Function's operand rest_position (read whole).
  ! With obstacles, write_obstacles writes their sidecar too.
  module procedure write_xdmf
    integer :: k
    type(xml_file) :: x
    character(len=:), allocatable :: plane, surf

    if (ierr /= 0) return
    plane = itoa(out%ny)//' '//itoa(out%nx)        ! /lattice/mass [ny][nx]
    surf = '1 '//plane                            ! the topology, one layer of points; the views
    call xml_open(x, out%safe%xmf_path, out%safe%h5_base, 'cloth', ierr, errmsg)
    if (ierr /= 0) return
    do k = 1, out%series%nt
      call put(x, '   <Grid Name="step_'//itoa(k - 1)//'" GridType="Uniform">')
      call put(x, '    <Time Value="'//real_es(out%series%times(k))//'"/>')
      call put(x, '    <Topology TopologyType="3DSMesh" Dimensions="'//surf//'"/>')
      call put(x, '    <Geometry GeometryType="XYZ">')
      call item(x, '     ', surf//' 3', '/xdmf/'//step_view(d_position, k - 1), F8)
      call put(x, '    </Geometry>')
      if (out%series%write_velocity) then
        call put(x, '    <Attribute Name="velocity" AttributeType="Vector" Center="Node">')
        call item(x, '     ', surf//' 3', '/xdmf/'//step_view(d_velocity, k - 1), F8)
        call put(x, '    </Attribute>')
      end if
      call put(x, '    <Attribute Name="rest_position" AttributeType="Vector" Center="Node">')
      call item(x, '     ', surf//' 3', '/xdmf/rest_position', F8)
      call put(x, '    </Attribute>')
      call put(x, '    <Attribute Name="mass" AttributeType="Scalar" Center="Node">')
      call item(x, '     ', surf, '/xdmf/mass', F8)
      call put(x, '    </Attribute>')
      call put(x, '    <Attribute Name="displacement" AttributeType="Vector" Center="Node">')
      call put(x, '     <DataItem ItemType="Function" Function="$0 - $1" Dimensions="'//surf//' 3" '//F8//'>')
      call item(x, '      ', surf//' 3', '/xdmf/'//step_view(d_position, k - 1), F8)
      call item(x, '      ', plane//' 3', '/lattice/rest_position', F8)
      call put(x, '     </DataItem>')
      call put(x, '    </Attribute>')
      call put(x, '   </Grid>')
    end do
    call xml_close(x, ierr, errmsg)
    if (out%obst%n > 0) call write_obstacles(out, ierr, errmsg)
  end procedure write_xdmf

  ! The obstacles' sidecar (submodule output_obstacles writes their data),
  ! checked with the same readers by tests/python/test_xdmf_obstacles.py: a
  ! temporal collection of n_output_steps spatial collections, one a step
  ! at its time, each of one uniform grid an obstacle, "obstacle_<k>_<shape>":
  ! Triangle topology /obstacles/obstacle_<k>/triangles (int32 [nf][3],
  ! 0-based), XYZ geometry /obstacles/obstacle_<k>/vertices (static: the
  ! same at every step) or /xdmf/obstacle_<k>_vertices_<t> (moving: the view
  ! of step t), and the cell array `obstacle` (its number k, int32,
  ! /obstacles/obstacle_<k>/number). Plain HDF items only (the Xdmf3
  ! readers evaluate no Function: "base vertices + translation" would be
  ! skipped there). Its own file: a second grid of <file>.xdmf would make
  ! pyvista.read of it a MultiBlock instead of the cloth's StructuredGrid.
  subroutine write_obstacles(out, ierr, errmsg)
    type(output_file), intent(in) :: out
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    integer :: k, m
    type(xml_file) :: x
    character(len=:), allocatable :: pre, vertices

    call xml_open(x, out%safe%obst_path, out%safe%h5_base, 'obstacles', ierr, errmsg)
    if (ierr /= 0) return
    do k = 1, out%series%nt
      call put(x, '   <Grid Name="step_'//itoa(k - 1)//'" GridType="Collection" CollectionType="Spatial">')
      call put(x, '    <Time Value="'//real_es(out%series%times(k))//'"/>')
      do m = 1, out%obst%n
        pre = '/obstacles/obstacle_'//itoa(m)
        vertices = pre//'/vertices'
        if (out%obst%moving(m)) vertices = '/xdmf/'//obstacle_view(m, k - 1)
        call put(x, '    <Grid Name="obstacle_'//itoa(m)//'_'//trim(out%obst%shape(m))//'" GridType="Uniform">')
        call put(x, '     <Topology TopologyType="Triangle" NumberOfElements="'//itoa(out%obst%nf(m))//'">')
        call item(x, '      ', itoa(out%obst%nf(m))//' 3', pre//'/triangles', I4)
        call put(x, '     </Topology>')
        call put(x, '     <Geometry GeometryType="XYZ">')
        call item(x, '      ', itoa(out%obst%nv(m))//' 3', vertices, F8)
        call put(x, '     </Geometry>')
        call put(x, '     <Attribute Name="obstacle" AttributeType="Scalar" Center="Cell">')
        call item(x, '      ', itoa(out%obst%nf(m)), pre//'/number', I4)
        call put(x, '     </Attribute>')
        call put(x, '    </Grid>')
      end do
      call put(x, '   </Grid>')
    end do
    call xml_close(x, ierr, errmsg)
  end subroutine write_obstacles

  ! ---------------------------------------------------------------------------
  ! Writing a sidecar.

  !> Start the sidecar path of the HDF5 file h5_base (its base name): its
  !> head, up to the opening of the temporal collection named grid (both
  !> sidecars are one; xml_close closes it).
  subroutine xml_open(x, path, h5_base, grid, ierr, errmsg)
    type(xml_file), intent(out) :: x
    character(*), intent(in) :: path, h5_base, grid
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=256) :: iom

    x%path = path
    x%h5 = xml_escape(h5_base)
    allocate(character(len=BUF_LEN) :: x%buf)
    x%nbuf = 0
    call tmp_open(path, x%tmp, x%u, x%good, iom)
    if (.not. x%good) then
      ierr = 1
      errmsg = 'output: cannot write '//path//': '//trim(iom)
    end if
    if (ierr /= 0) return
    call put(x, '<?xml version="1.0" ?>')
    call put(x, '<Xdmf Version="3.0">')
    call put(x, ' <Domain>')
    call put(x, '  <Grid Name="'//grid//'" GridType="Collection" CollectionType="Temporal">')
  end subroutine xml_open

  !> Close the temporal collection of xml_open and put the sidecar in place
  !> (or remove its new file after a failed write).
  subroutine xml_close(x, ierr, errmsg)
    type(xml_file), intent(inout) :: x
    integer, intent(inout) :: ierr
    character(*), intent(inout) :: errmsg
    character(len=256) :: iom

    call put(x, '  </Grid>')
    call put(x, ' </Domain>')
    call put(x, '</Xdmf>')
    call flush_buf(x)
    if (.not. x%good) then
      ierr = 1
      errmsg = 'output: write error on '//x%path
    end if
    call tmp_commit(x%u, x%tmp, x%path, x%good, iom)
    if (.not. x%good .and. ierr == 0) then
      ierr = 1
      errmsg = 'output: cannot put '//x%path//' in place: '//trim(iom)
    end if
  end subroutine xml_close

  !> One line of the sidecar.
  subroutine put(x, line)
    type(xml_file), intent(inout) :: x
    character(*), intent(in) :: line
    if (x%nbuf + len(line) + 1 > len(x%buf)) call flush_buf(x)
    if (len(line) + 1 > len(x%buf)) then
      call tmp_write(x%u, line//achar(10), x%good)
    else
      x%buf(x%nbuf + 1:x%nbuf + len(line) + 1) = line//achar(10)
      x%nbuf = x%nbuf + len(line) + 1
    end if
  end subroutine put

  subroutine flush_buf(x)
    type(xml_file), intent(inout) :: x
    if (x%nbuf > 0) call tmp_write(x%u, x%buf(1:x%nbuf), x%good)
    x%nbuf = 0
  end subroutine flush_buf

  !> A plain HDF DataItem of the dataset path (C-order dims) of number type ntype (F8, I4).
  subroutine item(x, indent, dims, path, ntype)
    type(xml_file), intent(inout) :: x
    character(*), intent(in) :: indent, dims, path, ntype
    call put(x, indent//'<DataItem Dimensions="'//dims//'" '//ntype//' Format="HDF">'//x%h5//':'//path//'</DataItem>')
  end subroutine item

  !> s with the characters that XML text and attribute values cannot hold escaped.
  pure function xml_escape(s) result(r)
    character(*), intent(in) :: s
    character(len=:), allocatable :: r
    integer :: i
    r = ''
    do i = 1, len(s)
      select case (s(i:i))
      case ('&'); r = r//'&amp;'
      case ('<'); r = r//'&lt;'
      case ('>'); r = r//'&gt;'
      case ('"'); r = r//'&quot;'
      case default; r = r//s(i:i)
      end select
    end do
  end function xml_escape

end submodule output_xdmf
