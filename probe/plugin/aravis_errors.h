// What a failed Aravis call says about the camera: gone (the stream reconnects) or refusing
// a value (bad input, the stream ends with the camera's message). Apart from the source so
// that the rule is tested on Aravis' own error codes (tests/probe/aravis_errors_test.cpp).
#pragma once

#include <arv.h>

namespace lp {

// A failed exposure write. A camera pulled mid-stream fails it (a GVCP timeout) before its
// heartbeat thread has flagged the link as lost (`link_down`), the later the busier the
// machine: the error's kind, or a value this camera took before, says it is the link, not
// the value. Only a value refused from the start is bad input (gige_fault.sh failed now and
// then under load when this ended the stream instead of reconnecting).
inline bool exposure_write_lost_camera(const GError& error, bool link_down, bool value_taken_before) {
  const bool link_error = error.domain == ARV_DEVICE_ERROR &&
                          (error.code == ARV_DEVICE_ERROR_TIMEOUT || error.code == ARV_DEVICE_ERROR_TRANSFER_ERROR ||
                           error.code == ARV_DEVICE_ERROR_PROTOCOL_ERROR || error.code == ARV_DEVICE_ERROR_NOT_CONNECTED);
  return link_down || link_error || value_taken_before;
}

}  // namespace lp
