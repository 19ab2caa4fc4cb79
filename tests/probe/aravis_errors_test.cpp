// Which failed exposure writes mean a lost camera (probe/plugin/aravis_errors.h), on
// Aravis' own error codes: the stream reconnects after those and ends after the others.
#include "probe/plugin/aravis_errors.h"

#include <gtest/gtest.h>

namespace lp {
namespace {

GError error_of(GQuark domain, int code) { return GError{domain, code, const_cast<gchar*>("test")}; }

TEST(AravisErrors, AWriteThatFailsOnTheLinkIsALostCameraEvenBeforeTheHeartbeatNotices) {
  for (int code : {ARV_DEVICE_ERROR_TIMEOUT, ARV_DEVICE_ERROR_TRANSFER_ERROR, ARV_DEVICE_ERROR_PROTOCOL_ERROR,
                   ARV_DEVICE_ERROR_NOT_CONNECTED})
    EXPECT_TRUE(exposure_write_lost_camera(error_of(ARV_DEVICE_ERROR, code), false, false)) << code;
}

TEST(AravisErrors, ARefusedValueIsBadInputUnlessTheCameraTookItBeforeOrTheLinkIsDown) {
  const GError refused = error_of(ARV_DEVICE_ERROR, ARV_DEVICE_ERROR_PROTOCOL_ERROR_INVALID_PARAMETER);
  EXPECT_FALSE(exposure_write_lost_camera(refused, false, false));
  EXPECT_FALSE(exposure_write_lost_camera(error_of(ARV_GC_ERROR, ARV_GC_ERROR_OUT_OF_RANGE), false, false));
  // The same kind of error for a value this camera accepted before: the camera changed, not the value.
  EXPECT_TRUE(exposure_write_lost_camera(refused, false, true));
  // The heartbeat already flagged the link: whatever the error says.
  EXPECT_TRUE(exposure_write_lost_camera(refused, true, false));
  // A timeout code from another domain is not a device link error.
  EXPECT_FALSE(exposure_write_lost_camera(error_of(ARV_GC_ERROR, ARV_DEVICE_ERROR_TIMEOUT), false, false));
}

}  // namespace
}  // namespace lp
