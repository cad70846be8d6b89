! SPDX-License-Identifier: BSD-2-Clause
!> Module output: the XDMF sidecar (<file>.xdmf) that ParaView and VTK (pyvista) read.
submodule (output) output_xdmf
  implicit none

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
  module procedure write_xdmf
    integer :: u, k, nbuf
    logical :: good
    character(len=256) :: iom
    character(len=:), allocatable :: plane, surf, f8, h5, tmp
    character(len=65536) :: buf                   ! lines gathered for one write(2)

    if (ierr /= 0) return
    h5 = xml_escape(out%safe%h5_base)                  ! the file's name in XML text
    plane = itoa(out%ny)//' '//itoa(out%nx)        ! /lattice/mass [ny][nx]
    surf = '1 '//plane                            ! the topology, one layer of points; the views
    f8 = 'NumberType="Float" Precision="8"'
    ! Written whole into a new file made exclusively beside it, then renamed
    ! onto the name: never through a symbolic link, never half-written.
    call tmp_open(out%safe%xmf_path, tmp, u, good, iom)
    if (.not. good) then
      ierr = 1
      errmsg = 'output: cannot write '//out%safe%xmf_path//': '//trim(iom)
      return
    end if
    nbuf = 0
    call put('<?xml version="1.0" ?>')
    call put('<Xdmf Version="3.0">')
    call put(' <Domain>')
    call put('  <Grid Name="cloth" GridType="Collection" CollectionType="Temporal">')
    do k = 1, out%series%nt
      call put('   <Grid Name="step_'//itoa(k - 1)//'" GridType="Uniform">')
      call put('    <Time Value="'//real_es(out%series%times(k))//'"/>')
      call put('    <Topology TopologyType="3DSMesh" Dimensions="'//surf//'"/>')
      call put('    <Geometry GeometryType="XYZ">')
      call item('     ', surf//' 3', '/xdmf/'//step_view(d_position, k - 1))
      call put('    </Geometry>')
      if (out%series%write_velocity) then
        call put('    <Attribute Name="velocity" AttributeType="Vector" Center="Node">')
        call item('     ', surf//' 3', '/xdmf/'//step_view(d_velocity, k - 1))
        call put('    </Attribute>')
      end if
      call put('    <Attribute Name="rest_position" AttributeType="Vector" Center="Node">')
      call item('     ', surf//' 3', '/xdmf/rest_position')
      call put('    </Attribute>')
      call put('    <Attribute Name="mass" AttributeType="Scalar" Center="Node">')
      call item('     ', surf, '/xdmf/mass')
      call put('    </Attribute>')
      call put('    <Attribute Name="displacement" AttributeType="Vector" Center="Node">')
      call put('     <DataItem ItemType="Function" Function="$0 - $1" Dimensions="'//surf//' 3" '//f8//'>')
      call item('      ', surf//' 3', '/xdmf/'//step_view(d_position, k - 1))
      call item('      ', plane//' 3', '/lattice/rest_position')
      call put('     </DataItem>')
      call put('    </Attribute>')
      call put('   </Grid>')
    end do
    call put('  </Grid>')
    call put(' </Domain>')
    call put('</Xdmf>')
    call flush_buf()
    if (.not. good) then
      ierr = 1
      errmsg = 'output: write error on '//out%safe%xmf_path
    end if
    call tmp_commit(u, tmp, out%safe%xmf_path, good, iom)
    if (.not. good .and. ierr == 0) then
      ierr = 1
      errmsg = 'output: cannot put '//out%safe%xmf_path//' in place: '//trim(iom)
    end if
  contains
    subroutine put(line)
      character(*), intent(in) :: line
      if (nbuf + len(line) + 1 > len(buf)) call flush_buf()
      if (len(line) + 1 > len(buf)) then
        call tmp_write(u, line//achar(10), good)
      else
        buf(nbuf + 1:nbuf + len(line) + 1) = line//achar(10)
        nbuf = nbuf + len(line) + 1
      end if
    end subroutine put

    subroutine flush_buf()
      if (nbuf > 0) call tmp_write(u, buf(1:nbuf), good)
      nbuf = 0
    end subroutine flush_buf

    !> A plain float64 HDF DataItem of the dataset path (C-order dims).
    subroutine item(indent, dims, path)
      character(*), intent(in) :: indent, dims, path
      call put(indent//'<DataItem Dimensions="'//dims//'" '//f8//' Format="HDF">'//h5//':'//path//'</DataItem>')
    end subroutine item
  end procedure write_xdmf


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
