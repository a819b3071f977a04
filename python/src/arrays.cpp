// Numpy <-> library plumbing shared by the binding files (bindings.hpp).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "bindings.hpp"

namespace fishcam::python {

using PointArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// (N, k) float64, C-contiguous: the input itself when it already is one (no copy),
// else a converted copy (forcecast). `what` names the argument in errors.
PointArray rows_of(const py::handle& input, py::ssize_t k, const char* what) {
  PointArray array = PointArray::ensure(input);
  if (!array) throw Error(std::string(what) + ": expected an array of numbers");
  if (array.ndim() != 2 || array.shape(1) != k) {
    std::string shape = "(";
    for (py::ssize_t i = 0; i < array.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(array.shape(i));
    throw Error(std::string(what) + ": expected shape (N, " + std::to_string(k) + "), got " + shape + ")");
  }
  return array;
}

// A numpy image as a cv::Mat header on its memory (no copy); see bindings.hpp.
cv::Mat as_mat(py::array& array, const char* what, bool labels, bool rows_apart) {
  // Rows apart: an HxW array whose rows are contiguous and do not overlap (a plane of
  // a cropped CxHxW image), read through its row step.
  const py::ssize_t item = array.itemsize();
  rows_apart = rows_apart && array.ndim() == 2 && array.strides(1) == item && array.strides(0) % item == 0 &&
               array.strides(0) >= array.shape(1) * item;
  if (!rows_apart && !(array.flags() & py::array::c_style)) {
    array = py::array::ensure(array, py::array::c_style);  // a contiguous copy: never strided reads
  }
  if (array.ndim() >= 2 && (array.shape(0) >= 32767 || array.shape(1) >= 32767)) {
    throw Error(std::string(what) + ": 32767 pixels or more per side (cv::remap takes fewer)");
  }
  const int ndim = static_cast<int>(array.ndim());
  if (ndim != 2 && !(ndim == 3 && !labels)) {
    throw Error(std::string(what) + (labels ? ": expected an HxW array" : ": expected an HxW or HxWxC array"));
  }
  const int channels = ndim == 3 ? static_cast<int>(array.shape(2)) : 1;
  if (channels < 1 || channels > 4)
    throw Error(std::string(what) + ": expected 1 to 4 channels, got " + std::to_string(channels));
  int depth = -1;
  if (py::isinstance<py::array_t<std::uint8_t>>(array)) depth = CV_8U;
  if (py::isinstance<py::array_t<std::uint16_t>>(array)) depth = CV_16U;
  if (!labels && py::isinstance<py::array_t<float>>(array)) depth = CV_32F;
  if (depth < 0) {
    throw Error(std::string(what) + ": expected dtype " + (labels ? "uint8 or uint16" : "uint8, uint16 or float32") +
                ", got " + std::string(py::str(array.dtype())));
  }
  // Inputs are only read: read-only arrays (np.asarray of a PIL image, a memory map
  // opened with mode 'r') are taken as they are.
  return cv::Mat(static_cast<int>(array.shape(0)), static_cast<int>(array.shape(1)), CV_MAKETYPE(depth, channels),
                 const_cast<void*>(array.data()),
                 rows_apart ? static_cast<std::size_t>(array.strides(0)) : std::size_t(cv::Mat::AUTO_STEP));
}

namespace {
// The OpenCV depth of an image array as_mat took (uint8, uint16 or float32).
int image_depth(const py::array& like) { return like.itemsize() == 1 ? CV_8U : like.itemsize() == 2 ? CV_16U : CV_32F; }
}  // namespace

bool is_planar_view(const py::array& array) {
  if (array.ndim() != 3 || array.shape(2) < 2) return false;
  const py::ssize_t item = array.itemsize(), w = array.shape(1);
  // Contiguous rows that do not overlap, the planes anywhere (a crop of a CxHxW image
  // too; an interleaved image has a column stride of C items).
  return array.strides(1) == item && array.strides(0) % item == 0 && array.strides(0) >= w * item &&
         array.strides(2) % item == 0;
}

std::vector<cv::Mat> image_planes(py::array& array, const char* what) {
  const auto channels = array.shape(2);
  if (channels > 4) throw Error(std::string(what) + ": expected 1 to 4 channels, got " + std::to_string(channels));
  std::vector<cv::Mat> planes;
  for (py::ssize_t c = 0; c < channels; ++c) {
    // A plane is an HxW view with contiguous rows (is_planar_view), checked as any
    // image; the header is taken on the array's own memory, which the caller keeps alive.
    py::array plane = array[py::make_tuple(py::ellipsis(), c)];
    const cv::Mat checked = as_mat(plane, what, false, true);
    const auto* lies = static_cast<const unsigned char*>(array.data()) + c * array.strides(2);
    if (checked.data != lies) throw Error(std::string(what) + ": internal: a plane was copied");
    planes.push_back(checked);
  }
  return planes;
}

py::array new_planar_image(const py::array& like, int height, int width, std::vector<cv::Mat>* planes) {
  const auto channels = like.shape(2);
  py::array out(like.dtype(), std::vector<py::ssize_t>{channels, height, width});
  const int depth = image_depth(like);
  auto* data = static_cast<unsigned char*>(out.mutable_data());
  planes->clear();
  for (py::ssize_t c = 0; c < channels; ++c) {
    planes->emplace_back(height, width, CV_MAKETYPE(depth, 1), data + c * height * width * like.itemsize());
  }
  return out.attr("transpose")(1, 2, 0);
}

// A new numpy array of height x width (x the channels of `like`), dtype of `like`,
// and a cv::Mat header on its memory.
py::array new_image(const py::array& like, int height, int width, cv::Mat* header) {
  std::vector<py::ssize_t> shape{height, width};
  if (like.ndim() == 3) shape.push_back(like.shape(2));
  py::array out(like.dtype(), shape);
  const int channels = like.ndim() == 3 ? static_cast<int>(like.shape(2)) : 1;
  const int depth = image_depth(like);
  *header = cv::Mat(height, width, CV_MAKETYPE(depth, channels), out.mutable_data());
  return out;
}

LabelSpan labels_of(const py::handle& input, const char* what, py::array* keep) {
  *keep = py::array::ensure(input, py::array::c_style);
  if (!*keep) throw Error(std::string(what) + ": expected an array of integer labels");
  const py::array& a = *keep;
  const auto n = static_cast<std::size_t>(a.size());
  if (py::isinstance<py::array_t<std::uint8_t>>(a)) return std::span(static_cast<const std::uint8_t*>(a.data()), n);
  if (py::isinstance<py::array_t<std::uint16_t>>(a)) return std::span(static_cast<const std::uint16_t*>(a.data()), n);
  if (py::isinstance<py::array_t<std::int32_t>>(a)) return std::span(static_cast<const std::int32_t*>(a.data()), n);
  if (py::isinstance<py::array_t<std::int64_t>>(a)) return std::span(static_cast<const std::int64_t*>(a.data()), n);
  throw Error(std::string(what) + ": expected dtype uint8, uint16, int32 or int64, got " +
              std::string(py::str(a.dtype())));
}

std::string shape_text(const py::array& a) {
  std::string out = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) out += (i ? ", " : "") + std::to_string(a.shape(i));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

std::string camera_state(const Camera& camera) { return format_camera(camera.parameters(), CameraFormat::fishcam); }

Camera camera_from_state(const std::string& state, const char* what) {
  return Camera(parse_camera(state, what, CameraFormat::fishcam));
}

}  // namespace fishcam::python
