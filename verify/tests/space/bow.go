// D1 climbs from 2 to 20 m on its way 16 m north, past the spot where D2
// waits at 10 m: its straight segment passes 6.6 m from D2, but a drone
// climbs and travels each at its own rate, so it may reach D2's spot
// before it has climbed past it.
package Bow

var (
	D1 Quadcopter
	D2 Quadcopter
)

func PAR_Mission() {
	SEQ_First()
	SEQ_Second()
}

func SEQ_First() {
	D1.Arm()
	D1.Takeoff(2)
	Await("parked")
	D1.FlyTo(16, 0, 20)
	Signal("passed")
	D1.FlyTo(0, 0, 20)
	D1.Land()
	D1.Disarm()
}

func SEQ_Second() {
	D2.Arm()
	D2.Takeoff(5)
	D2.FlyTo(16, -3, 10)
	Signal("parked")
	Await("passed")
	D2.Land()
	D2.Disarm()
}
