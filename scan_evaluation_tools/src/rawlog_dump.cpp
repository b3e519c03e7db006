// rawlog_dump: one text line per action/observation pair of an MRPT rawlog (for tests and
// for checking a conversion by eye). See the package README for the columns.
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>
#include <mrpt/system/datetime.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

int main(int argc, char** argv)
{
  if (argc != 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help")
  {
    std::cerr << "usage: rawlog_dump FILE.rawlog\n"
                 "Prints per action/observation pair: entry stamp odom_dx odom_dy odom_dyaw beams aperture "
                 "max_range valid no_return sensor_x sensor_y sensor_z sensor_yaw first_angle last_angle\n";
    return 2;
  }
  mrpt::io::CFileGZInputStream file;
  if (!file.open(argv[1]))
  {
    std::cerr << "rawlog_dump: cannot read " << argv[1] << "\n";
    return 1;
  }
  auto archive = mrpt::serialization::archiveFrom(file);
  std::printf(
    "# entry stamp odom_dx odom_dy odom_dyaw beams aperture max_range valid no_return sensor_x sensor_y "
    "sensor_z sensor_yaw first_angle last_angle\n");
  std::size_t entry = 0;
  double dx = NAN, dy = NAN, dyaw = NAN;
  bool action_without_frame = false;
  while (true)
  {
    mrpt::serialization::CSerializable::Ptr object;
    const auto object_start = file.getPosition();  // in the uncompressed stream
    try
    {
      archive >> object;
    }
    catch (const std::exception& e)
    {
      // MRPT signals the end of file with an exception too. It is the end only where an object
      // ends: a cut inside an object (or a pair cut after its action) or any other read error
      // is a broken rawlog, and the exit code must say so.
      if (file.getPosition() == object_start)
        break;
      std::cerr << "rawlog_dump: " << argv[1] << ": read error after " << entry << " entries: " << e.what() << "\n";
      return 1;
    }
    if (auto actions = std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(object))
    {
      action_without_frame = true;
      const auto movement = actions->getBestMovementEstimation();
      const auto mean = movement ? movement->poseChange->getMeanVal() : mrpt::poses::CPose2D(NAN, NAN, NAN);
      dx = mean.x();
      dy = mean.y();
      dyaw = mean.phi();
    }
    else if (auto frame = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(object))
    {
      action_without_frame = false;
      const auto scan = frame->getObservationByClass<mrpt::obs::CObservation2DRangeScan>();
      if (!scan)
      {
        continue;
      }
      std::size_t valid = 0, no_return = 0;
      for (std::size_t i = 0; i < scan->getScanSize(); ++i)
      {
        valid += scan->getScanRangeValidity(i) ? 1 : 0;
        no_return += !scan->getScanRangeValidity(i) && scan->getScanRange(i) >= scan->maxRange ? 1 : 0;
      }
      const auto& s = scan->sensorPose;
      const std::size_t n = scan->getScanSize();
      std::printf("%zu %.9f %.9f %.9f %.9f %zu %.9f %.6f %zu %zu %.9f %.9f %.9f %.9f %.9f %.9f\n", entry,
                  mrpt::Clock::toDouble(scan->timestamp), dx, dy, dyaw, scan->getScanSize(), scan->aperture,
                  scan->maxRange, valid, no_return, s.x(), s.y(), s.z(), s.yaw(), n ? scan->getScanAngle(0) : NAN,
                  n ? scan->getScanAngle(n - 1) : NAN);
      ++entry;
    }
  }
  if (action_without_frame)
  {
    std::cerr << "rawlog_dump: " << argv[1] << ": truncated: the last action has no observation\n";
    return 1;
  }
  return 0;
}
