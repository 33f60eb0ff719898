// Test oracle: applies the real tf2_geometry_msgs (ROS 1, Debian libtf2-geometry-msgs-dev) and
// KDL to the data given on stdin, for tests/test_core_geometry_tf2.py. Written for zentf.
// Each input line: KIND tx ty tz qx qy qz qw DATA...; each output line: the result's numbers.
//   point x y z | vector x y z | pose px py pz qx qy qz qw | quat x y z w
//   transform tx ty tz qx qy qz qw | posecov px py pz qx qy qz qw c0..c35
//   wrench fx fy fz tx ty tz | twist vx vy vz wx wy wz (KDL::Frame * KDL::Twist, as tf2_kdl)
//   rpy (no data: Matrix3x3(rotation).getRPY -> roll pitch yaw) | setrpy roll pitch yaw (-> x y z w)
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>
#include <kdl/frames.hpp>
#include <cstdio>
#include <cstring>
#include <vector>

static void out(const std::vector<double>& v) {
  for (size_t i = 0; i < v.size(); ++i) std::printf(i ? " %.17g" : "%.17g", v[i]);
  std::printf("\n");
}

static bool read(std::vector<double>& v, size_t n) {
  v.resize(n);
  for (size_t i = 0; i < n; ++i)
    if (std::scanf("%lf", &v[i]) != 1) return false;
  return true;
}

int main() {
  char kind[32];
  std::vector<double> t, d;
  while (std::scanf("%31s", kind) == 1) {
    if (!read(t, 7)) return 2;
    geometry_msgs::TransformStamped tf;
    tf.transform.translation.x = t[0]; tf.transform.translation.y = t[1]; tf.transform.translation.z = t[2];
    tf.transform.rotation.x = t[3]; tf.transform.rotation.y = t[4];
    tf.transform.rotation.z = t[5]; tf.transform.rotation.w = t[6];
    if (!std::strcmp(kind, "point")) {
      if (!read(d, 3)) return 2;
      geometry_msgs::Point a, b; a.x = d[0]; a.y = d[1]; a.z = d[2];
      tf2::doTransform(a, b, tf); out({b.x, b.y, b.z});
    } else if (!std::strcmp(kind, "vector")) {
      if (!read(d, 3)) return 2;
      geometry_msgs::Vector3 a, b; a.x = d[0]; a.y = d[1]; a.z = d[2];
      tf2::doTransform(a, b, tf); out({b.x, b.y, b.z});
    } else if (!std::strcmp(kind, "pose")) {
      if (!read(d, 7)) return 2;
      geometry_msgs::Pose a, b;
      a.position.x = d[0]; a.position.y = d[1]; a.position.z = d[2];
      a.orientation.x = d[3]; a.orientation.y = d[4]; a.orientation.z = d[5]; a.orientation.w = d[6];
      tf2::doTransform(a, b, tf);
      out({b.position.x, b.position.y, b.position.z, b.orientation.x, b.orientation.y, b.orientation.z,
           b.orientation.w});
    } else if (!std::strcmp(kind, "quat")) {
      if (!read(d, 4)) return 2;
      geometry_msgs::Quaternion a, b; a.x = d[0]; a.y = d[1]; a.z = d[2]; a.w = d[3];
      tf2::doTransform(a, b, tf); out({b.x, b.y, b.z, b.w});
    } else if (!std::strcmp(kind, "transform")) {
      if (!read(d, 7)) return 2;
      geometry_msgs::TransformStamped a, b;
      a.transform.translation.x = d[0]; a.transform.translation.y = d[1]; a.transform.translation.z = d[2];
      a.transform.rotation.x = d[3]; a.transform.rotation.y = d[4];
      a.transform.rotation.z = d[5]; a.transform.rotation.w = d[6];
      tf2::doTransform(a, b, tf);
      const geometry_msgs::Transform& r = b.transform;
      out({r.translation.x, r.translation.y, r.translation.z, r.rotation.x, r.rotation.y, r.rotation.z,
           r.rotation.w});
    } else if (!std::strcmp(kind, "posecov")) {
      if (!read(d, 43)) return 2;
      geometry_msgs::PoseWithCovarianceStamped a, b;
      a.pose.pose.position.x = d[0]; a.pose.pose.position.y = d[1]; a.pose.pose.position.z = d[2];
      a.pose.pose.orientation.x = d[3]; a.pose.pose.orientation.y = d[4];
      a.pose.pose.orientation.z = d[5]; a.pose.pose.orientation.w = d[6];
      for (int i = 0; i < 36; ++i) a.pose.covariance[i] = d[7 + i];
      tf2::doTransform(a, b, tf);
      const geometry_msgs::Pose& p = b.pose.pose;
      std::vector<double> r = {p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                               p.orientation.z, p.orientation.w};
      for (int i = 0; i < 36; ++i) r.push_back(b.pose.covariance[i]);
      out(r);
    } else if (!std::strcmp(kind, "wrench")) {
      if (!read(d, 6)) return 2;
      geometry_msgs::WrenchStamped a, b;
      a.wrench.force.x = d[0]; a.wrench.force.y = d[1]; a.wrench.force.z = d[2];
      a.wrench.torque.x = d[3]; a.wrench.torque.y = d[4]; a.wrench.torque.z = d[5];
      tf2::doTransform(a, b, tf);
      out({b.wrench.force.x, b.wrench.force.y, b.wrench.force.z, b.wrench.torque.x, b.wrench.torque.y,
           b.wrench.torque.z});
    } else if (!std::strcmp(kind, "twist")) {
      if (!read(d, 6)) return 2;
      KDL::Frame f(KDL::Rotation::Quaternion(t[3], t[4], t[5], t[6]), KDL::Vector(t[0], t[1], t[2]));
      KDL::Twist tw = f * KDL::Twist(KDL::Vector(d[0], d[1], d[2]), KDL::Vector(d[3], d[4], d[5]));
      out({tw.vel.x(), tw.vel.y(), tw.vel.z(), tw.rot.x(), tw.rot.y(), tw.rot.z()});
    } else if (!std::strcmp(kind, "rpy")) {
      tf2::Quaternion q(t[3], t[4], t[5], t[6]);
      double roll, pitch, yaw;
      tf2::Matrix3x3(q).getRPY(roll, pitch, yaw);
      out({roll, pitch, yaw});
    } else if (!std::strcmp(kind, "setrpy")) {
      if (!read(d, 3)) return 2;
      tf2::Quaternion q;
      q.setRPY(d[0], d[1], d[2]);
      out({q.x(), q.y(), q.z(), q.w()});
    } else {
      std::fprintf(stderr, "unknown kind %s\n", kind);
      return 2;
    }
  }
  return 0;
}
