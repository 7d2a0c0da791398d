// D1 climbs 40 m above its take-off height.
package Ceiling

var D1 Quadcopter

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(5)
	D1.FlyByZ(40)
	D1.Land()
}
