#include "bag/bag_options.hpp"

#include <string>
#include <utility>

namespace desslam {

void BagOptions::validate() const {
  const char* s = kSection;
  for (const auto& [key, topic] : {std::pair<const char*, const std::string&>{"rgb_topic", rgb_topic},
                                   {"depth_topic", depth_topic}, {"camera_info_topic", camera_info_topic}}) {
    const bool name_ok = topic.size() > 1 && topic.front() == '/' &&
                         topic.find_first_of(" \t\r\n") == std::string::npos;
    requireThat(name_ok, s, key,
                "must be a full ROS topic name as a bag stores it, e.g. /camera/rgb/image_color, got '" + topic + "'");
  }
}

}  // namespace desslam
