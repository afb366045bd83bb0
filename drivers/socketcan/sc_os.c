/* sc_os.c - raw SocketCAN calls (the OS boundary of the CAN motor backends). */
#include "omni4/drivers/sc_os.h"

#include "omni4/base/clock.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

/* struct omni4_can_frame's id carries the kernel's flag bits and masks unchanged (can_proto.h). */
_Static_assert(OMNI4_CAN_EFF_FLAG == CAN_EFF_FLAG && OMNI4_CAN_RTR_FLAG == CAN_RTR_FLAG,
               "frame flags differ from SocketCAN's");
_Static_assert(SC_OS_MASK_EXACT_SFF == (CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG) &&
                   SC_OS_MASK_EXACT_EFF == (CAN_EFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG),
               "filter masks differ from SocketCAN's");
_Static_assert(OMNI4_CAN_SFF_MASK == CAN_SFF_MASK && OMNI4_CAN_EFF_MASK == CAN_EFF_MASK,
               "ID masks differ from SocketCAN's");

int sc_os_open_filters(const char *iface, const struct sc_os_filter *filt, int n_filt, int *fd)
{
	struct sockaddr_can addr = {.can_family = AF_CAN};
	struct can_filter filters[SC_OS_MAX_FILTERS];
	const can_err_mask_t err_mask =
	    CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_PROT | CAN_ERR_TX_TIMEOUT | CAN_ERR_RESTARTED;
	int s, rc;

	if (n_filt < 0 || n_filt > SC_OS_MAX_FILTERS || strlen(iface) >= IFNAMSIZ)
		return -EINVAL;
	s = socket(PF_CAN, SOCK_RAW, CAN_RAW);
	if (s < 0)
		return -errno;
	addr.can_ifindex = (int)if_nametoindex(iface);
	if (!addr.can_ifindex) {
		rc = -ENODEV;
		goto err_close;
	}
	for (int i = 0; i < n_filt; i++) {
		filters[i].can_id = filt[i].id;
		filters[i].can_mask = filt[i].mask;
	}
	if (n_filt && setsockopt(s, SOL_CAN_RAW, CAN_RAW_FILTER, filters,
	                         (socklen_t)(n_filt * sizeof(filters[0])))) {
		rc = -errno;
		goto err_close;
	}
	if (setsockopt(s, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask))) {
		rc = -errno;
		goto err_close;
	}
	if (fcntl(s, F_SETFL, fcntl(s, F_GETFL) | O_NONBLOCK)) {
		rc = -errno;
		goto err_close;
	}
	if (bind(s, (struct sockaddr *)&addr, sizeof(addr))) {
		rc = -errno;
		goto err_close;
	}
	*fd = s;
	return 0;

err_close:
	close(s);
	return rc;
}

int sc_os_open(const char *iface, const uint32_t *ids, int n_ids, int *fd)
{
	struct sc_os_filter filt[SC_OS_MAX_FILTERS];

	if (n_ids < 0 || n_ids > SC_OS_MAX_FILTERS)
		return -EINVAL;
	for (int i = 0; i < n_ids; i++)
		filt[i] = (struct sc_os_filter){ids[i], SC_OS_MASK_EXACT_SFF};
	return sc_os_open_filters(iface, filt, n_ids, fd);
}

void sc_os_close(int fd)
{
	if (fd >= 0)
		close(fd);
}

int sc_os_send(int fd, const struct omni4_can_frame *f)
{
	/* A standard ID keeps 11 bits, an extended one 29 and its flag; RTR either way. */
	const uint32_t keep = (f->id & CAN_EFF_FLAG) ? CAN_EFF_FLAG | CAN_EFF_MASK : CAN_SFF_MASK;
	struct can_frame cf = {.can_id = f->id & (keep | CAN_RTR_FLAG), .can_dlc = f->dlc};

	memcpy(cf.data, f->data, sizeof(cf.data));
	const ssize_t n = send(fd, &cf, sizeof(cf), MSG_DONTWAIT);

	if (n < 0)
		return errno == ENOBUFS ? -EAGAIN : -errno;
	return n == (ssize_t)sizeof(cf) ? 0 : -EIO;
}

int sc_os_recv(int fd, struct omni4_can_frame *f, uint32_t *err_class)
{
	struct can_frame cf;
	const ssize_t n = recv(fd, &cf, sizeof(cf), MSG_DONTWAIT);

	if (n < 0)
		return errno == EWOULDBLOCK ? -EAGAIN : -errno;
	if (n != (ssize_t)sizeof(cf))
		return -EIO;
	if (cf.can_id & CAN_ERR_FLAG) {
		*err_class = (cf.can_id & CAN_ERR_BUSOFF) ? SC_ERR_BUSOFF : SC_ERR_OTHER;
		return 2;
	}
	f->id =
	    cf.can_id & ((cf.can_id & CAN_EFF_FLAG ? CAN_EFF_MASK | CAN_EFF_FLAG : CAN_SFF_MASK) |
	                 CAN_RTR_FLAG);
	f->dlc = cf.can_dlc > 8 ? 8 : cf.can_dlc;
	memcpy(f->data, cf.data, 8);
	return 1;
}

int64_t sc_os_now_us(void)
{
	return omni4_monotonic_us();
}

const char *sc_os_strerror(int rc, char *buf, size_t n)
{
	const char *hint = "";

	if (rc == -EAFNOSUPPORT || rc == -EPROTONOSUPPORT)
		hint =
		    " (this kernel has no CAN support: load the can and can_raw modules, or use a "
		    "kernel with CONFIG_CAN; for a test bus see docs/can.md)";
	else if (rc == -ENODEV)
		hint =
		    " (no network interface of that name: 'ip link' lists them; [can] iface names "
		    "it; for a test bus see docs/can.md)";
	else if (rc == -ENETDOWN)
		hint =
		    " (the interface is down: 'ip link set IFACE up', with its bitrate for a real "
		    "bus; see docs/can.md)";
	snprintf(buf, n, "%s%s", strerror(-rc), hint);
	return buf;
}
